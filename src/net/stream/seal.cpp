#include "volcast/net/stream/seal.hpp"

#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <cstring>
#include <memory>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast {
namespace {

// Each thread's cipher and digest contexts, made once: sealing and opening allocate nothing per
// chunk once warm.
struct Contexts {
  EVP_CIPHER_CTX* cipher = EVP_CIPHER_CTX_new();
  EVP_MD_CTX* digest = EVP_MD_CTX_new();
  ~Contexts() {
    EVP_CIPHER_CTX_free(cipher);
    EVP_MD_CTX_free(digest);
  }
};

Contexts& contexts() {
  thread_local Contexts c;
  if (!c.cipher || !c.digest) throw Error("sealed frame set: cannot make OpenSSL contexts");
  return c;
}

const EVP_CIPHER* aes_128_gcm() {
  static EVP_CIPHER* cipher = EVP_CIPHER_fetch(nullptr, "AES-128-GCM", nullptr);
  if (!cipher) throw Error("sealed frame set: OpenSSL has no AES-128-GCM");
  return cipher;
}

const EVP_MD* sha256() {
  static EVP_MD* md = EVP_MD_fetch(nullptr, "SHA256", nullptr);
  if (!md) throw Error("sealed frame set: OpenSSL has no SHA-256");
  return md;
}

// The 12-byte GCM nonce of chunk `i`: i as u32 little-endian, then zeros (protocol.hpp).
std::array<uint8_t, 12> nonce_of(size_t i) {
  std::array<uint8_t, 12> n{};
  wire::store<uint32_t>(n.data(), static_cast<uint32_t>(i));
  return n;
}

void digest_of(std::span<const uint8_t> data, uint8_t out[protocol::kSealDigestBytes]) {
  EVP_MD_CTX* ctx = contexts().digest;
  unsigned int n = 0;
  if (EVP_DigestInit_ex2(ctx, sha256(), nullptr) != 1 ||
      EVP_DigestUpdate(ctx, data.data(), data.size()) != 1 || EVP_DigestFinal_ex(ctx, out, &n) != 1)
    throw Error("sealed frame set: SHA-256 failed");
}

// Runs fn(i) for each chunk, on `pool` when given and there is more than one chunk.
template <typename Fn>
void for_each_chunk(size_t chunks, WorkerPool* pool, Fn&& fn) {
  if (pool && chunks > 1)
    pool->parallel_for(chunks, fn);
  else
    for (size_t i = 0; i < chunks; ++i) fn(i);
}

}  // namespace

void seal_body(std::span<const uint8_t> body, uint32_t chunk_bytes, protocol::SealedFrameSet& seal,
               std::vector<uint8_t>& sealed, WorkerPool* pool) {
  if (chunk_bytes < protocol::kMinSealChunkBytes || chunk_bytes > protocol::kMaxSealChunkBytes ||
      (chunk_bytes & (chunk_bytes - 1)) != 0)
    throw Error("sealed frame set: chunk length " + std::to_string(chunk_bytes) +
                " is not a power of two within the protocol's limits");
  const size_t chunks = (body.size() + chunk_bytes - 1) / chunk_bytes;
  if (chunks > protocol::kMaxSealChunks || body.size() > UINT32_MAX)
    throw Error("sealed frame set: a body of " + std::to_string(body.size()) +
                " bytes is too large to seal");
  if (RAND_bytes(seal.key.data(), static_cast<int>(seal.key.size())) != 1) {
    ERR_clear_error();
    throw Error("sealed frame set: the random source failed");
  }
  seal.body_bytes = static_cast<uint32_t>(body.size());
  seal.chunk_bytes = chunk_bytes;
  seal.chunks.resize(chunks);
  sealed.resize(body.size());
  const EVP_CIPHER* cipher = aes_128_gcm();
  for_each_chunk(chunks, pool, [&](size_t i) {
    const size_t at = i * chunk_bytes, n = std::min<size_t>(chunk_bytes, body.size() - at);
    EVP_CIPHER_CTX* ctx = contexts().cipher;
    const auto nonce = nonce_of(i);
    int out = 0, tail = 0;
    if (EVP_EncryptInit_ex2(ctx, cipher, seal.key.data(), nonce.data(), nullptr) != 1 ||
        EVP_EncryptUpdate(ctx, sealed.data() + at, &out, body.data() + at, static_cast<int>(n)) !=
            1 ||
        EVP_EncryptFinal_ex(ctx, sealed.data() + at + out, &tail) != 1 ||
        EVP_CIPHER_CTX_ctrl(ctx, EVP_CTRL_GCM_GET_TAG, protocol::kSealTagBytes,
                            seal.chunks[i].tag.data()) != 1) {
      ERR_clear_error();
      throw Error("sealed frame set: AES-GCM failed on chunk " + std::to_string(i));
    }
    digest_of({sealed.data() + at, n}, seal.chunks[i].digest.data());
  });
}

void open_sealed_chunk(const protocol::SealedFrameSet& seal, size_t i, std::span<uint8_t> chunk) {
  const size_t chunks = seal.chunks.size();
  const std::string name =
      "sealed frame set: chunk " + std::to_string(i + 1) + " of " + std::to_string(chunks);
  const size_t at = i * size_t{seal.chunk_bytes};
  if (i >= chunks || at >= seal.body_bytes ||
      chunk.size() != std::min<size_t>(seal.chunk_bytes, seal.body_bytes - at))
    throw Error(name + ": " + std::to_string(chunk.size()) + " bytes do not match the descriptor");
  uint8_t digest[protocol::kSealDigestBytes];
  digest_of(chunk, digest);
  if (CRYPTO_memcmp(digest, seal.chunks[i].digest.data(), sizeof digest) != 0)
    throw Error(name + " does not match its SHA-256 (altered on the way)");
  EVP_CIPHER_CTX* ctx = contexts().cipher;
  const auto nonce = nonce_of(i);
  std::array<uint8_t, protocol::kSealTagBytes> tag = seal.chunks[i].tag;
  int out = 0, tail = 0;
  if (EVP_DecryptInit_ex2(ctx, aes_128_gcm(), seal.key.data(), nonce.data(), nullptr) != 1 ||
      EVP_CIPHER_CTX_ctrl(ctx, EVP_CTRL_GCM_SET_TAG, static_cast<int>(tag.size()), tag.data()) !=
          1 ||
      EVP_DecryptUpdate(ctx, chunk.data(), &out, chunk.data(), static_cast<int>(chunk.size())) !=
          1) {
    ERR_clear_error();
    throw Error(name + ": AES-GCM failed");
  }
  if (EVP_DecryptFinal_ex(ctx, chunk.data() + out, &tail) != 1) {
    ERR_clear_error();
    throw Error(name + " fails its AES-GCM tag (wrong key or altered)");
  }
}

void open_sealed(const protocol::SealedFrameSet& seal, std::span<uint8_t> data, WorkerPool* pool) {
  const size_t chunks = seal.chunks.size();
  if (data.size() != seal.body_bytes || seal.chunk_bytes == 0 ||
      chunks != (data.size() + seal.chunk_bytes - 1) / seal.chunk_bytes)
    throw Error("sealed frame set: " + std::to_string(data.size()) + " bytes and " +
                std::to_string(chunks) + " chunks do not match a body of " +
                std::to_string(seal.body_bytes) + " bytes");
  for_each_chunk(chunks, pool, [&](size_t i) {
    const size_t at = i * seal.chunk_bytes;
    open_sealed_chunk(seal, i,
                      data.subspan(at, std::min<size_t>(seal.chunk_bytes, data.size() - at)));
  });
}

}  // namespace volcast
