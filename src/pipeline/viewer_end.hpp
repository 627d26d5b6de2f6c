#pragma once
// Internal to volcast_pipeline: how a viewer's session ended (receiver.cpp runs it) -- the end
// that an error means, whether it is a cut to reconnect after, the first cause among several, and
// the last step of every session.
#include <exception>
#include <string>

#include "volcast/pipeline/receiver.hpp"

namespace volcast::viewer_end {

/// What ended a session that threw `error`: a ClientError's kind (timed out, rejected, protocol,
/// connection lost), else kError.
ViewerEnd end_of(const std::exception_ptr& error);

/// `error`'s what(), or "unknown error".
std::string message_of(const std::exception_ptr& error);

/// Whether `end` is an error (kTimedOut and after): run_viewer throws ViewerError for it.
bool is_error(ViewerEnd end);

/// Every end of a session: writes the figures to options.stats_json if asked (a failure to write
/// them is thrown unless the session already ended on an error, which is the one reported), and
/// throws ViewerError holding `result` on an error; else returns it.
ViewerResult finish(const ViewerOptions& opt, ViewerResult result);

/// Records an error that ended the session before anything was received.
void fail(ViewerResult& result, const std::exception_ptr& error);

/// Whether `error` is a cut a viewer reconnects after: the connection broke or fell silent.
bool is_cut(const std::exception_ptr& error);

/// Why the session ended, first cause first: the presenter's error, the receive's error, the
/// frame count reached, the presenter closing it, else `stopped_by` (what the watchdog saw).
void set_end(ViewerResult& result, const ViewerOptions& opt, const std::exception_ptr& render_error,
             const std::exception_ptr& receive_error, uint64_t received, bool presenter_closed,
             ViewerEnd stopped_by);

}  // namespace volcast::viewer_end
