#pragma once
// Private to src/session: the hub (hub.hpp) and the participant (participant_impl.hpp) dispatch
// what they receive through routes, one per message type, listed by feature (message_table.hpp's
// Feature) in each feature's file. These index the lists once by type and say which feature
// routes which type (for the check against the message table).
#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "volcast/session/message_table.hpp"

namespace volcast::session {

/// One feature's routes (`Route` has a `type`).
template <typename Route>
struct FeatureRoutes {
  std::span<const Route> routes;
  Feature feature;
};

/// The route of each type byte (null: none) from every feature's list.
template <typename Route>
std::array<const Route*, 256> index_routes(std::span<const FeatureRoutes<Route>> features) {
  std::array<const Route*, 256> by_type{};
  for (const FeatureRoutes<Route>& f : features)
    for (const Route& r : f.routes) by_type[static_cast<uint8_t>(r.type)] = &r;
  return by_type;
}

/// Each routed type with the feature whose list routes it, in the features' order.
template <typename Route>
std::vector<std::pair<Type, Feature>> routed_types(std::span<const FeatureRoutes<Route>> features) {
  std::vector<std::pair<Type, Feature>> out;
  for (const FeatureRoutes<Route>& f : features)
    for (const Route& r : f.routes) out.emplace_back(r.type, f.feature);
  return out;
}

}  // namespace volcast::session
