#pragma once
// A child process for the tests and tools that run the LCM processes together (the e2e
// test, dynfilter-soak): started with posix_spawn with its own LCM_DEFAULT_URL, optionally
// with stdout and stderr appended to a log file; SIGTERM and reaped when the object goes.
// Header-only: link the CMake target dynfilter_process_child for the include path.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

extern char** environ;

namespace dynfilter::processes {

class Child {
 public:
  /// Starts args[0] (a path) with args[1...]; the environment is the caller's with
  /// LCM_DEFAULT_URL replaced by @p url. @p log_path: append stdout and stderr there
  /// (empty: inherit the caller's).
  Child(const std::vector<std::string>& args, const std::string& url, const std::string& log_path = "") {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    std::vector<std::string> env_strings{"LCM_DEFAULT_URL=" + url};
    for (char** e = environ; *e; ++e)
      if (std::string(*e).rfind("LCM_DEFAULT_URL=", 0) != 0) env_strings.emplace_back(*e);
    std::vector<char*> envp;
    for (auto& e : env_strings) envp.push_back(e.data());
    envp.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (!log_path.empty()) {
      posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(),
                                       O_WRONLY | O_CREAT | O_APPEND, 0644);
      posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    }
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), envp.data()) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~Child() { stop(); }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  /// SIGTERM, wait, and the exit code (-1: killed by a signal or never started). Once
  /// stopped (or found exited by running()), returns the recorded exit code.
  int stop() {
    if (pid_ <= 0) return exit_code_;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    record(status);
    return exit_code_;
  }
  /// True while the process has not exited (reaps it if it has: exitCode() then tells).
  bool running() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      record(status);
      return false;
    }
    return true;
  }
  /// The process id while running, -1 after.
  pid_t pid() const { return pid_; }
  int exitCode() const { return exit_code_; }
  /// The signal that ended the process (0 if it exited by itself or is running).
  int termSignal() const { return term_signal_; }

 private:
  void record(int status) {
    pid_ = -1;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    term_signal_ = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  }
  pid_t pid_ = -1;
  int exit_code_ = -1;
  int term_signal_ = 0;
};

}  // namespace dynfilter::processes
