#pragma once
// The streaming server: accepts viewers over TCP (asio), negotiates codecs per viewer, sends the
// site's calibration once, then every frame set published to it.
//
// Pacing: the server keeps only the newest frame set. Each viewer has its own thread and encoders;
// it sends a frame set only while fewer than `window` are unacknowledged, and then always the
// newest one, so a viewer that cannot keep up skips whole frame sets (counted as dropped) instead
// of queueing them in socket buffers, and never slows another viewer or the publisher. Temporal
// codecs stay decodable across skips because each viewer's encoder codes deltas against the last
// frame that viewer was sent.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "volcast/core/frame.hpp"
#include "volcast/net/protocol.hpp"

namespace volcast {

struct ServerConfig {
  std::string bind_address = "127.0.0.1";  ///< "0.0.0.0" to accept remote viewers
  uint16_t port = 7300;                    ///< 0 picks a free port (see Server::port)
  int key_frame_interval = 60;             ///< frames between key frames for temporal codecs
  int window = 2;                          ///< frame sets in flight (sent, not acknowledged)
  int max_clients = 16;
  int handshake_timeout_ms = 5000;  ///< a viewer must send Hello within this time
  int stall_timeout_ms = 10000;     ///< a viewer that accepts or acknowledges nothing this long is
                                    ///< disconnected
};

/// What the server knows about one viewer (for logs and tests).
struct ViewerReport {
  std::string peer;
  std::string depth_codec, color_codec;
  uint64_t frames_sent = 0;
  uint64_t frames_dropped = 0;  ///< frame sets published while this viewer was busy
  uint64_t bytes_sent = 0;
  bool connected = false;
  std::string error;  ///< why it ended, if it did
};

class Server {
 public:
  /// Binds and starts accepting. Throws Error if the address or port cannot be bound.
  Server(std::vector<protocol::CameraInfo> cameras, ServerConfig config);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  uint16_t port() const;
  /// Makes `frames` the newest frame set (one frame per camera, in camera order). Never blocks
  /// on viewers. Throws Error if the camera count differs from the site's.
  void publish(std::shared_ptr<const FrameSet> frames);
  std::vector<ViewerReport> viewers() const;
  /// Stops accepting, disconnects every viewer and joins all threads. Idempotent.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
