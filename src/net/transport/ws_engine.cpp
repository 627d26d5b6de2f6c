// Compiled as C++17 (see ws_engine.hpp).
#include "volcast/net/transport/ws_engine.hpp"

#define _WEBSOCKETPP_CPP11_STL_
#include <websocketpp/config/core.hpp>
#include <websocketpp/frame.hpp>
#include <websocketpp/server.hpp>

namespace volcast::detail {

namespace {

// WebSocket++'s core config (iostream transport) with its loggers off: the server logs itself.
struct Config : websocketpp::config::core {
  typedef Config type;
  static const websocketpp::log::level elog_level = websocketpp::log::elevel::none;
  static const websocketpp::log::level alog_level = websocketpp::log::alevel::none;
};
using Endpoint = websocketpp::server<Config>;
using Hdl = websocketpp::connection_hdl;
namespace status = websocketpp::http::status_code;

// Headers of every answer. `r`: a connection (its response) or a parser::response.
template <typename Response>
void common_headers(Response& r) {
  // One request per connection (WebSocket++ does not keep HTTP connections alive): said, so
  // that a browser never sends its next request on a connection about to close.
  r.append_header("Connection", "close");
  r.append_header("Cache-Control", "no-store");
  r.append_header("X-Content-Type-Options", "nosniff");
  r.append_header("Referrer-Policy", "no-referrer");
}

// The answer to a request that announces a body: nothing here takes one.
template <typename Response>
void refuse_body(Response& r) {
  r.set_status(status::request_entity_too_large);
  common_headers(r);
  r.append_header("Content-Type", "text/plain");
  r.set_body(
      "request bodies are not accepted: this server serves its page files to GET and HEAD\n");
}

}  // namespace

struct WsEngine::Impl {
  Endpoint endpoint;
  Endpoint::connection_ptr con;
  std::shared_ptr<const WebAssets> assets;
  std::string output, inbox, error, path;
  State state = State::kRequest;
  bool answer_pings = false;

  Impl(std::shared_ptr<const WebAssets> a, size_t max_message_bytes) : assets(std::move(a)) {
    endpoint.clear_access_channels(websocketpp::log::alevel::all);
    endpoint.clear_error_channels(websocketpp::log::elevel::all);
    endpoint.set_user_agent("volcast");
    endpoint.set_max_message_size(max_message_bytes);
    // A request announcing a body (Content-Length > 0) fails at its head, unread: 413.
    endpoint.set_max_http_body_size(0);
    con = endpoint.get_connection();
    con->set_write_handler([this](Hdl, const char* data, size_t n) {
      output.append(data, n);
      return std::error_code();
    });
    con->set_vector_write_handler(
        [this](Hdl, const std::vector<websocketpp::transport::buffer>& parts) {
          for (const auto& b : parts) output.append(b.buf, b.len);
          return std::error_code();
        });
    con->set_shutdown_handler([this](Hdl) {
      if (state == State::kRequest) state = State::kResponded;
      return std::error_code();
    });
    con->set_validate_handler([this](Hdl) {
      path = con->get_resource();
      if (!con->get_request_header("Transfer-Encoding").empty()) {
        refuse_body(*con);  // a chunked body (WebSocket++ reads none): answered by the fail handler
        return false;
      }
      return path == "/stream";
    });
    con->set_http_handler([this](Hdl) { respond(); });
    con->set_open_handler([this](Hdl) { state = State::kOpen; });
    // Before the peer is authenticated nothing is buffered for it: its pings get no pong.
    con->set_ping_handler([this](Hdl, std::string) { return answer_pings; });
    con->set_message_handler([this](Hdl, Endpoint::message_ptr m) {
      if (m->get_opcode() != websocketpp::frame::opcode::binary) {
        con->close(websocketpp::close::status::unsupported_data, "binary messages only");
        return;
      }
      inbox.append(m->get_payload());
    });
    con->set_close_handler([this](Hdl) {
      state = State::kClosed;
      if (error.empty())
        error = "peer closed the connection (WebSocket close " +
                std::to_string(con->get_remote_close_code()) + ")";
    });
    con->set_fail_handler([this](Hdl) {
      if (con->get_response_code() == status::request_entity_too_large) {
        // A body announced (Content-Length > 0 or Transfer-Encoding): answered at the head.
        websocketpp::http::parser::response r;
        r.set_version("HTTP/1.1");
        refuse_body(r);
        output = r.raw();
        state = State::kResponded;
        return;
      }
      state = State::kClosed;
      if (error.empty()) error = "WebSocket failed: " + con->get_ec().message();
    });
    con->start();
  }

  // A pending read holds the connection (its handler keeps a shared_ptr to it): end it, so that
  // the connection is freed with the engine.
  ~Impl() { con->fatal_error(); }

  void respond() {
    path = con->get_resource();
    const std::string method = con->get_request().get_method();
    if (!con->get_request_header("Transfer-Encoding").empty()) {
      refuse_body(*con);  // chunked: WebSocket++ reads no such body, nor does anything here
      return;
    }
    common_headers(*con);
    if (method != "GET" && method != "HEAD") {
      con->set_status(status::method_not_allowed);
      con->append_header("Allow", "GET, HEAD");
      return;
    }
    const bool head = method == "HEAD";  // GET's answer without its body
    std::string key = path.substr(0, path.find_first_of("?#"));
    if (key == "/") key = "/index.html";
    const auto it = assets ? assets->find(key) : WebAssets::const_iterator();
    if (!assets || it == assets->end()) {
      con->set_status(status::not_found);
      con->append_header("Content-Type", "text/plain");
      set_body("not found\n", head);
      return;
    }
    con->set_status(status::ok);
    con->append_header("Content-Type", it->second.content_type);
    // The page's own scripts, its worker and WebAssembly; the stream on this origin only.
    con->append_header("Content-Security-Policy",
                       "default-src 'self'; script-src 'self' 'wasm-unsafe-eval'; "
                       "connect-src 'self'; img-src 'self' blob: data:; worker-src 'self'");
    set_body(it->second.bytes, head);
  }

  void set_body(const std::string& bytes, bool head) {
    if (head)
      con->replace_header("Content-Length", std::to_string(bytes.size()));
    else
      con->set_body(bytes);
  }
};

WsEngine::WsEngine(std::shared_ptr<const WebAssets> assets, size_t max_message_bytes)
    : impl_(std::make_unique<Impl>(std::move(assets), max_message_bytes)) {}
WsEngine::~WsEngine() = default;

void WsEngine::feed(const uint8_t* data, size_t n) {
  const char* p = reinterpret_cast<const char*>(data);
  while (n > 0 && (impl_->state == State::kRequest || impl_->state == State::kOpen)) {
    const size_t taken = impl_->con->read_some(p, n);
    if (taken == 0) break;  // the connection stopped reading (closing)
    p += taken;
    n -= taken;
  }
}

std::string& WsEngine::output() {
  return impl_->output;
}
std::string& WsEngine::inbox() {
  return impl_->inbox;
}
WsEngine::State WsEngine::state() const {
  return impl_->state;
}
std::string WsEngine::error() const {
  return impl_->error;
}
std::string WsEngine::path() const {
  return impl_->path;
}
void WsEngine::set_max_message_bytes(size_t bytes) {
  impl_->con->set_max_message_size(bytes);
}
void WsEngine::set_answer_pings(bool answer) {
  impl_->answer_pings = answer;
}

std::string WsEngine::binary_frame_header(uint64_t payload_bytes) {
  const websocketpp::frame::basic_header basic(websocketpp::frame::opcode::binary, payload_bytes,
                                               true, false);
  const websocketpp::frame::extended_header extended(payload_bytes);
  return websocketpp::frame::prepare_header(basic, extended);
}

}  // namespace volcast::detail
