// skatelib_bench LIB [target_velocity_mps strides]: open time, allocation-free sample() and window(10) times.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "skatelib/motion_library.hpp"

using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: skatelib_bench LIB [target_velocity_mps strides]\n");
    return 2;
  }
  const auto t_open = Clock::now();
  const auto lib = skatelib::MotionLibrary::open(argv[1]);
  const double open_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_open).count();
  const auto& e = lib.select(argc > 2 ? std::atof(argv[2]) : 0.5, argc > 3 ? std::atoi(argv[3]) : 2);
  std::vector<double> x(e.nx), u(e.nu);
  std::vector<int8_t> c(e.nc);
  double sink = 0.0;
  const int n = 1000000;
  double best_sample = 1e30, best_window = 1e30;
  for (int rep = 0; rep < 5; ++rep) {
    auto t0 = Clock::now();
    for (int i = 0; i < n; ++i) {
      e.sample_into(0.613 + 1e-9 * (i & 1023), x.data(), u.data(), c.data());
      sink += x[0];
    }
    best_sample = std::min(best_sample, std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / n);
    t0 = Clock::now();
    for (int i = 0; i < n / 10; ++i) sink += e.window(0.61 + 1e-9 * (i & 1023), 10, 1.0 / 30).state[0];
    best_window = std::min(best_window, std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / (n / 10));
  }
  std::printf("entry %s: open %.2f ms, sample %.1f ns, window(10) %.1f ns (checksum %.3f)\n", e.key.c_str(), open_ms,
              best_sample, best_window, sink * 1e-12);
  return 0;
}
