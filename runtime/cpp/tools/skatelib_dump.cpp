// skatelib_dump LIB: reads queries from stdin and prints what the reader returns, for cross-checks
// against the Python runtime.
//   "S key t"        -> "S state... | control... | contact..."
//   "W key t0 n dt"  -> n lines "W t state... | control... | contact..."
//   "K"              -> one line per entry: "K key K nx nu nc success"
// Numbers are printed with 17 significant digits (round-trip exact).
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>

#include "skatelib/motion_library.hpp"

static void row(const double* x, int n) {
  for (int j = 0; j < n; ++j) std::printf(" %.17g", x[j]);
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: skatelib_dump LIB < queries\n");
    return 2;
  }
  try {
    const auto lib = skatelib::MotionLibrary::open(argv[1]);
    std::string line;
    while (std::getline(std::cin, line)) {
      std::istringstream in(line);
      std::string op, key;
      in >> op;
      if (op == "K") {
        for (const auto& e : lib.entries)
          std::printf("K %s %d %d %d %d %d\n", e.key.c_str(), e.K, e.nx, e.nu, e.nc, e.success ? 1 : 0);
      } else if (op == "S") {
        double t;
        in >> key >> t;
        const auto s = lib.at(key).sample(t);
        std::printf("S");
        row(s.state.data(), static_cast<int>(s.state.size()));
        std::printf(" |");
        row(s.control.data(), static_cast<int>(s.control.size()));
        std::printf(" |");
        for (int8_t c : s.contact) std::printf(" %d", c);
        std::printf("\n");
      } else if (op == "W") {
        double t0, dt;
        int n;
        in >> key >> t0 >> n >> dt;
        const auto& e = lib.at(key);
        const auto w = e.window(t0, n, dt);
        for (int k = 0; k < n; ++k) {
          std::printf("W %.17g", w.t[k]);
          row(&w.state[k * e.nx], e.nx);
          std::printf(" |");
          row(&w.control[k * e.nu], e.nu);
          std::printf(" |");
          for (int j = 0; j < e.nc; ++j) std::printf(" %d", w.contact[k * e.nc + j]);
          std::printf("\n");
        }
      }
    }
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "skatelib_dump: %s\n", ex.what());
    return 3;
  }
  return 0;
}
