// How a viewer's session ended (viewer_end.hpp).
#include "viewer_end.hpp"

#include <spdlog/spdlog.h>

#include "volcast/net/stream/client.hpp"

namespace volcast::viewer_end {

ViewerEnd end_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const ClientError& e) {
    switch (e.kind()) {
      case ClientError::Kind::kTimedOut:
        return ViewerEnd::kTimedOut;
      case ClientError::Kind::kRejected:
        return ViewerEnd::kRejected;
      case ClientError::Kind::kProtocol:
        return ViewerEnd::kProtocolError;
      case ClientError::Kind::kConnectionLost:
        return ViewerEnd::kConnectionLost;
    }
  } catch (...) {
  }
  return ViewerEnd::kError;
}

std::string message_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown error";
  }
}

bool is_error(ViewerEnd end) {
  return end >= ViewerEnd::kTimedOut;
}

ViewerResult finish(const ViewerOptions& opt, ViewerResult result) {
  if (!opt.stats_json.empty()) {
    try {
      write_stats_json(opt.stats_json, result);
    } catch (const std::exception& e) {
      if (!is_error(result.ended)) throw;
      spdlog::error("{}", e.what());  // the session's own error is the one to report
    }
  }
  if (is_error(result.ended)) {
    const std::string message = result.error;
    throw ViewerError(message, std::make_shared<const ViewerResult>(std::move(result)));
  }
  return result;
}

void fail(ViewerResult& result, const std::exception_ptr& error) {
  result.ended = end_of(error);
  result.error = message_of(error);
}

bool is_cut(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const ClientError& e) {
    return e.kind() == ClientError::Kind::kTimedOut ||
           e.kind() == ClientError::Kind::kConnectionLost;
  } catch (...) {
  }
  return false;
}

void set_end(ViewerResult& result, const ViewerOptions& opt, const std::exception_ptr& render_error,
             const std::exception_ptr& receive_error, uint64_t received, bool presenter_closed,
             ViewerEnd stopped_by) {
  if (render_error) {  // first: a failed presenter closes the session, which may break a receive
    result.ended = ViewerEnd::kError;
    result.error = "renderer: " + message_of(render_error);
  } else if (receive_error) {
    result.ended = end_of(receive_error);
    result.error = message_of(receive_error);
  } else if (opt.frames > 0 && received >= static_cast<uint64_t>(opt.frames)) {
    result.ended = ViewerEnd::kFramesReached;
  } else if (presenter_closed && stopped_by == ViewerEnd::kServerClosed) {
    result.ended = ViewerEnd::kClosed;  // the presenter ended it before the watchdog saw it
  } else {
    result.ended = stopped_by;  // seconds reached, interrupted, closed, or else the server closed
  }
}

}  // namespace volcast::viewer_end
