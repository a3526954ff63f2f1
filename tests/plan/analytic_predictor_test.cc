#include "tests/plan/analytic_predictor.h"

#include <gtest/gtest.h>

#include <vector>

namespace excite::plan::testing {
namespace {

// The stand-in's closed-form Jacobians against central differences: the other
// tests trust them.
TEST(AnalyticPredictorTest, JacobiansMatchFiniteDifferences) {
  for (int du : {1, 2}) {
    const AnalyticPendulum model(du);
    const int zd = model.z_dim();
    Eigen::MatrixXd z = Eigen::MatrixXd::Random(5, zd) * 1.5;
    Eigen::MatrixXd mean, var;
    std::vector<Eigen::MatrixXd> jm, jv;
    model.Predict(z, &mean, &var, &jm, &jv);
    ASSERT_EQ(jm.size(), 5u);
    EXPECT_GT(var.minCoeff(), 0.0);
    for (int i = 0; i < 5; ++i) {
      for (int l = 0; l < zd; ++l) {
        const double h = 1e-6;
        Eigen::MatrixXd zp = z.row(i), zm = z.row(i);
        zp(0, l) += h;
        zm(0, l) -= h;
        Eigen::MatrixXd mp, vp, mm, vm;
        model.Predict(zp, &mp, &vp, nullptr, nullptr);
        model.Predict(zm, &mm, &vm, nullptr, nullptr);
        for (int j = 0; j < 2; ++j) {
          EXPECT_NEAR(jm[i](j, l), (mp(0, j) - mm(0, j)) / (2 * h), 1e-7)
              << "du=" << du << " i=" << i << " j=" << j << " l=" << l;
          EXPECT_NEAR(jv[i](j, l), (vp(0, j) - vm(0, j)) / (2 * h), 1e-7)
              << "du=" << du << " i=" << i << " j=" << j << " l=" << l;
        }
      }
    }
  }
}

}  // namespace
}  // namespace excite::plan::testing
