// The tests' precompiled header: the heavy third-party headers every test binary parses
// (tests/CMakeLists.txt: one PCH, reused by each test). Only headers of well-kept libraries here;
// a test still includes what it uses.
#pragma once
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>
