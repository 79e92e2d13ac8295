// Wall-clock seconds since construction (or restart), for telemetry and benchmarks.
#pragma once

#include <chrono>

namespace weft {

class Timer {
 public:
  using Clock = std::chrono::steady_clock;
  Timer() : start_(Clock::now()) {}
  void restart() { start_ = Clock::now(); }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

 private:
  Clock::time_point start_;
};

}  // namespace weft
