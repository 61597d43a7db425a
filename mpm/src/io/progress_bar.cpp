// Terminal progress: a redrawn bar for people watching, decile lines for log files.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <utility>

#include "mpm/output.h"

namespace mpm::io {
namespace {

constexpr double kRedrawInterval = 0.1;  // [s] a faster redraw only costs terminal time
constexpr int kBarWidth = 30;            // [characters]

double nowSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// "3.2 s" below a minute, "4m05s" above, so long runs stay readable.
std::string formatDuration(double seconds) {
  char text[32];
  if (seconds < 60.0) {
    std::snprintf(text, sizeof text, "%.1f s", seconds);
  } else {
    const long long whole = static_cast<long long>(seconds + 0.5);
    std::snprintf(text, sizeof text, "%lldm%02llds", whole / 60, whole % 60);
  }
  return text;
}

/// Remaining time extrapolated from the mean rate so far; "?" before any unit is done.
std::string formatEta(double elapsed, long long done, long long total) {
  if (done <= 0) return "?";
  if (done >= total) return formatDuration(0.0);
  return formatDuration(elapsed * static_cast<double>(total - done) / static_cast<double>(done));
}

}  // namespace

ProgressBar::ProgressBar(std::string label, long long total)
    : label_(std::move(label)),
      total_(total),
      tty_(isatty(fileno(stderr)) != 0),
      startSeconds_(nowSeconds()) {}

void ProgressBar::update(long long done) {
  if (finished_) return;
  if (done < 0) done = 0;
  if (total_ > 0 && done > total_) done = total_;
  const double now = nowSeconds();
  const double elapsed = now - startSeconds_;
  // integer shares, so that 60 of 200 is decile 3 and not 2.9999; an empty job is complete
  const long long percent = total_ > 0 ? done * 100 / total_ : 100;
  const long long decile = total_ > 0 ? done * 10 / total_ : 10;

  if (tty_) {
    const bool complete = percent >= 100;
    if (lastDrawSeconds_ >= 0.0 && now - lastDrawSeconds_ < kRedrawInterval && !complete) return;
    lastDrawSeconds_ = now;
    const int filled = static_cast<int>(percent * kBarWidth / 100);
    const std::string bar = std::string(filled, '#') + std::string(kBarWidth - filled, '.');
    // \r returns to the line start, \033[K erases what a longer previous line left
    std::fprintf(stderr, "\r%s [%s] %lld/%lld (%lld%%) %s, ETA %s\033[K", label_.c_str(),
                 bar.c_str(), done, total_, percent, formatDuration(elapsed).c_str(),
                 formatEta(elapsed, done, total_).c_str());
    std::fflush(stderr);
    drawnOnTty_ = true;
    return;
  }

  if (decile <= lastPrintedDecile_) return;
  lastPrintedDecile_ = decile;
  std::fprintf(stderr, "%s: %lld/%lld (%lld%%) %s, ETA %s\n", label_.c_str(), done, total_,
               percent, formatDuration(elapsed).c_str(),
               formatEta(elapsed, done, total_).c_str());
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (finished_) return;
  update(total_ > 0 ? total_ : 0);
  if (tty_) std::fputc('\n', stderr);
  finished_ = true;
}

ProgressBar::~ProgressBar() {
  // a bar abandoned midway (e.g. by an exception) must not claim 100%; on a terminal it
  // only ends its line so that later output starts on a fresh one
  if (!finished_ && tty_ && drawnOnTty_) std::fputc('\n', stderr);
}

}  // namespace mpm::io
