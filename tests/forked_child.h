#pragma once
// The fork tests' child process: a process that forks (Python's multiprocessing, for data
// generation) must go on stepping its scenes in the child, whose only thread is the one
// that forked. A child that waits for a thread it does not have hangs: the alarm ends it.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstddef>
#include <cstring>
#include <vector>

#include "mpm/error.h"

namespace mpm::test {

/// Forks; the child runs `body` under a 60 s alarm and exits with what it returns. Returns
/// the child's pid in the parent (-1 if fork failed).
template <class Body>
pid_t forkChild(Body&& body) {
  const pid_t child = fork();
  if (child == 0) {
    alarm(60);
    _exit(body());
  }
  return child;
}

/// Waits for `child` and expects it to have exited with 0; `codes` says what its other exit
/// codes mean.
inline void expectChildSucceeded(pid_t child, const char* codes = "") {
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_FALSE(WIFSIGNALED(status)) << "the child was killed by signal " << WTERMSIG(status)
                                    << (WTERMSIG(status) == SIGALRM ? " (the alarm: it hung)" : "");
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << codes;
}

/// The child's exit code for `call`, which must throw an Error whose message holds
/// `text`: 0 if it does, 1 if it returns, 2 for another error.
template <class Call>
int throwsSaying(Call&& call, const char* text) {
  try {
    call();
  } catch (const Error& e) {
    return std::strstr(e.what(), text) ? 0 : 2;
  }
  return 1;
}

/// Writes `values` whole to `fd`: the child's exit code, 0 when all went.
template <class T>
int writeAll(int fd, const std::vector<T>& values) {
  const ssize_t bytes = (ssize_t)(values.size() * sizeof(T));
  return write(fd, values.data(), (size_t)bytes) == bytes ? 0 : 3;
}

/// Reads `count` values of T from `fd` (fewer if it closes first: the size tells).
template <class T>
std::vector<T> readAll(int fd, size_t count) {
  std::vector<T> out(count);
  size_t got = 0;
  char* dst = reinterpret_cast<char*>(out.data());
  for (ssize_t r; got < count * sizeof(T) && (r = ::read(fd, dst + got, count * sizeof(T) - got)) > 0;)
    got += (size_t)r;
  out.resize(got / sizeof(T));
  return out;
}

}  // namespace mpm::test
