#pragma once
// The viewer's side of the stream protocol: connects, names its codecs, receives the calibration
// and then decoded frame sets.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "volcast/core/frame.hpp"
#include "volcast/net/protocol.hpp"

namespace volcast {

struct ClientConfig {
  std::string host = "127.0.0.1";
  uint16_t port = 7300;
  std::string depth_codec = "trvl";
  std::string color_codec = "jpeg";
};

/// A decoded frame set plus what it cost on the wire.
struct ReceivedFrameSet {
  FrameSet frames;                  ///< decoded depth (mm) and color per camera
  std::vector<size_t> depth_bytes;  ///< encoded depth size per camera
  std::vector<size_t> color_bytes;  ///< encoded color size per camera
  size_t message_bytes = 0;         ///< whole message including headers
};

class Client {
 public:
  /// Connects and completes the handshake. Throws Error if the server cannot be reached, rejects
  /// the codecs (the server's reason is in the message), or answers with a malformed Welcome.
  explicit Client(const ClientConfig& config);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const protocol::Welcome& welcome() const;
  /// Blocks for the next frame set and decodes it into `out` (buffers reused). Returns false when
  /// the server closed the connection or close() was called. Throws Error on a malformed message or
  /// a frame that does not match the camera's calibrated size.
  bool receive(ReceivedFrameSet& out);
  /// Closes the connection; a receive() blocked in another thread returns false. Thread-safe.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
