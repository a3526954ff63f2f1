#include "server/gp/refit_schedule.h"

#include <algorithm>
#include <cmath>

namespace excite::gp {

bool RefitDue(const RefitSchedule& schedule, int sample_count, int samples_since_fit) {
  const int fitted_samples = std::max(0, sample_count - samples_since_fit);
  const double needed = std::max(static_cast<double>(schedule.every_samples),
                                 std::ceil(schedule.growth * fitted_samples));
  return samples_since_fit >= needed;
}

}  // namespace excite::gp
