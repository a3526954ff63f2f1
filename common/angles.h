#ifndef EXCITE_COMMON_ANGLES_H_
#define EXCITE_COMMON_ANGLES_H_

#include <cmath>

namespace excite {

inline constexpr double kPi = 3.14159265358979323846;

// `a` on the circle, in (-pi, pi]: the difference of two angles as the shorter
// way round (pi itself stays pi, -pi becomes pi).
inline double WrapAngle(double a) {
  const double r = std::remainder(a, 2.0 * kPi);  // in [-pi, pi]
  return r <= -kPi ? r + 2.0 * kPi : r;
}

}  // namespace excite

#endif  // EXCITE_COMMON_ANGLES_H_
