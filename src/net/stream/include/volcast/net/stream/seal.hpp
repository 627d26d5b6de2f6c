#pragma once
// Sealing a frame set's body once per tier (protocol.hpp, message 1.2 SealedFrameSet): AES-128-GCM
// under a fresh random key, in chunks that are sealed and opened in parallel, each with a detached
// tag and the SHA-256 of its ciphertext. The key, tags and digests go to each viewer inside its own
// TLS session; the sealed bytes, the same for every viewer of the tier, go outside TLS. So TLS
// encrypts a few hundred bytes per viewer and frame set instead of the whole body (AES-GCM over
// every viewer's copy was most of what TLS cost a server with many viewers).
// Through OpenSSL's EVP interface (AES-NI and SHA-NI where the CPU has them).
#include <cstdint>
#include <span>
#include <vector>

#include "volcast/net/protocol/frame_set.hpp"

namespace volcast {

class WorkerPool;

/// Chunk length (bytes) a server seals with: small enough that a frame set of a few hundred KiB
/// is opened in parallel on a viewer's cores, large enough that per-chunk costs vanish.
inline constexpr uint32_t kSealChunkBytes = 128u << 10;

/// Seals `body` into `sealed` (resized to body.size(); capacity reused) under a new random key,
/// in chunks of `chunk_bytes` (a power of two within protocol.hpp's limits), and fills `seal`'s
/// body length, chunk length, key, tags and digests (its send time and head copy are left alone).
/// Chunks run in parallel on `pool` (nullptr: on the calling thread). Throws Error if the random
/// source or the cipher fails, or the body needs more than protocol::kMaxSealChunks chunks.
void seal_body(std::span<const uint8_t> body, uint32_t chunk_bytes, protocol::SealedFrameSet& seal,
               std::vector<uint8_t>& sealed, WorkerPool* pool);

/// Opens `data` (the seal.body_bytes sealed bytes that followed `seal`) in place: checks each
/// chunk's SHA-256, then its tag, and decrypts it. Chunks run in parallel on `pool` (nullptr: on
/// the calling thread). Throws Error("sealed frame set: chunk I of N ...") naming the first chunk
/// that fails; `data` is then partly decrypted and must be discarded.
void open_sealed(const protocol::SealedFrameSet& seal, std::span<uint8_t> data, WorkerPool* pool);

/// Opens chunk `i` of `seal` alone, in place: `chunk` holds exactly its sealed bytes (bytes
/// [i * chunk_bytes, min((i + 1) * chunk_bytes, body_bytes)) of the body). For a viewer that opens
/// each chunk as it arrives, while the next is still on the way. Throws Error like open_sealed,
/// also for an index out of range or a chunk of the wrong length.
void open_sealed_chunk(const protocol::SealedFrameSet& seal, size_t i, std::span<uint8_t> chunk);

}  // namespace volcast
