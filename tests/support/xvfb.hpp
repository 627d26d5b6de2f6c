#pragma once
// An X server without a screen (Xvfb) for tests that open windows: started on a free display
// number, waited for (it reports the number, its socket in /tmp/.X11-unix appears), killed when
// the object goes.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace volcast::test {

class Xvfb {
 public:
  /// Starts Xvfb on a display it finds free itself (-displayfd: no race with other tests doing the
  /// same) and waits up to 60 s (a loaded machine is slow) for it to say which, and for its socket.
  /// On failure running() is false and error() says why.
  Xvfb() {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) {
      error_ = "pipe2() failed";
      return;
    }
    // The write end becomes Xvfb's fd 3: keep it off 3 here, or dup2 would not clear its CLOEXEC.
    const int write_end = fcntl(fds[1], F_DUPFD_CLOEXEC, 10);
    close(fds[1]);
    fds[1] = write_end;
    std::vector<std::string> args = {"Xvfb", "-displayfd",   "3",         "-screen",
                                     "0",    "1280x1024x24", "-nolisten", "tcp"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 3);  // the read end closes on exec
    const int failed = posix_spawnp(&pid_, "Xvfb", &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (failed) {
      pid_ = -1;
      close(fds[0]);
      error_ = "cannot start Xvfb (is the xvfb package installed?)";
      return;
    }
    std::string number;  // Xvfb writes "N\n" once it accepts connections
    pollfd p{fds[0], POLLIN, 0};
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (number.find('\n') == std::string::npos && std::chrono::steady_clock::now() < deadline) {
      if (poll(&p, 1, 100) <= 0) continue;
      char c[16];
      const ssize_t n = read(fds[0], c, sizeof c);
      if (n <= 0) break;  // Xvfb exited
      number.append(c, static_cast<size_t>(n));
    }
    close(fds[0]);
    if (number.find('\n') == std::string::npos) {
      error_ = "Xvfb did not report a display within 60 s";
      stop();
      return;
    }
    display_ = std::stoi(number);
    const std::filesystem::path socket = "/tmp/.X11-unix/X" + std::to_string(display_);
    for (int i = 0; i < 600 && !std::filesystem::exists(socket); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!std::filesystem::exists(socket)) {
      error_ = "Xvfb's socket " + socket.string() + " did not appear";
      display_ = -1;
      stop();
    }
  }
  ~Xvfb() { stop(); }
  Xvfb(const Xvfb&) = delete;
  Xvfb& operator=(const Xvfb&) = delete;

  bool running() const { return display_ >= 0; }
  const std::string& error() const { return error_; }
  /// ":N", the value for DISPLAY.
  std::string display() const { return ":" + std::to_string(display_); }

 private:
  void stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  pid_t pid_ = -1;
  int display_ = -1;
  std::string error_;
};

/// Sets an environment variable for the lifetime of the object (unset with a null value), then
/// restores it.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) {
      old_ = old;
      had_ = true;
    }
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ~ScopedEnv() {
    if (had_)
      setenv(name_.c_str(), old_.c_str(), 1);
    else
      unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_, old_;
  bool had_ = false;
};

}  // namespace volcast::test
