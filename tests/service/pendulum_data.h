#ifndef EXCITE_TESTS_SERVICE_PENDULUM_DATA_H_
#define EXCITE_TESTS_SERVICE_PENDULUM_DATA_H_

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "excite/v1/exploration_service.pb.h"

namespace excite::testing {

// A damped pendulum theta'' = -(g/l) sin(theta) - b theta' + u (m = l = 1),
// state (theta, theta'), stepped with RK4 (5 substeps of dt / 5).
inline std::array<double, 2> PendulumStep(const std::array<double, 2>& x, double u,
                                          double dt = 0.05) {
  constexpr double kG = 9.81;
  constexpr double kB = 0.1;
  auto f = [&](const std::array<double, 2>& s) {
    return std::array<double, 2>{s[1], -kG * std::sin(s[0]) - kB * s[1] + u};
  };
  std::array<double, 2> s = x;
  const double h = dt / 5;
  for (int i = 0; i < 5; ++i) {
    const auto k1 = f(s);
    const auto k2 = f({s[0] + 0.5 * h * k1[0], s[1] + 0.5 * h * k1[1]});
    const auto k3 = f({s[0] + 0.5 * h * k2[0], s[1] + 0.5 * h * k2[1]});
    const auto k4 = f({s[0] + h * k3[0], s[1] + h * k3[1]});
    for (int j = 0; j < 2; ++j) s[j] += h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
  }
  return s;
}

// `count` transitions at uniformly random (x, u) in [-pi, pi] x [-4, 4] x
// [-3, 3], with sequence numbers first_sequence, first_sequence + 1, ...
inline std::vector<v1::Transition> PendulumTransitions(int count, int64_t first_sequence,
                                                       uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> theta(-3.14, 3.14), omega(-4, 4), input(-3, 3);
  std::vector<v1::Transition> out;
  for (int i = 0; i < count; ++i) {
    const std::array<double, 2> x{theta(rng), omega(rng)};
    const double u = input(rng);
    const std::array<double, 2> y = PendulumStep(x, u);
    v1::Transition t;
    t.add_state(x[0]);
    t.add_state(x[1]);
    t.add_input(u);
    t.add_next_state(y[0]);
    t.add_next_state(y[1]);
    t.set_sequence(first_sequence + i);
    t.set_timestamp_s(1.7e9 + 0.05 * static_cast<double>(first_sequence + i));
    out.push_back(t);
  }
  return out;
}

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SERVICE_PENDULUM_DATA_H_
