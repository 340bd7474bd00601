#include "fluoro_tracker/registration/cauchy_residual.h"

#include <cmath>

#include <gtest/gtest.h>

using fluoro_tracker::registration::CauchyResidual;

namespace {

// The Cauchy loss the residual stands for: rho(d^2) = b^2 log(1 + d^2 / b^2).
double cauchyLoss(double d, double b) {
  return b * b * std::log1p(d * d / (b * b));
}

}  // namespace

// Its square is the Cauchy loss of the distance, whichever branch (the series below q = 0.01,
// the logarithm above) and sign; it keeps the distance's sign.
TEST(CauchyResidual, SquaresToTheCauchyLossAndKeepsTheSign) {
  for (double b : {0.5, 1.0, 4.0, 16.0}) {
    const CauchyResidual kernel(b);
    for (double d : {1e-8, 1e-3, 0.05, 0.0999, 0.1001, 0.3, 1.0, 3.0, 10.0, 60.0}) {
      for (double sign : {1.0, -1.0}) {
        double derivative = 0.0;
        const double r = kernel(sign * d, &derivative);
        EXPECT_NEAR(r * r, cauchyLoss(d, b), 1e-6 * cauchyLoss(d, b) + 1e-30)
            << "b " << b << " d " << sign * d;
        EXPECT_EQ(std::signbit(r), std::signbit(sign)) << "b " << b << " d " << sign * d;
      }
    }
  }
  double derivative = 0.0;
  EXPECT_EQ(CauchyResidual(4.0)(0.0, &derivative), 0.0);
  EXPECT_EQ(derivative, 1.0);  // the residual is the distance near zero
}

// The derivative it reports is that of the residual (central differences), so Ceres' Jacobians
// are right; it falls toward zero far out, where samples stop pulling.
TEST(CauchyResidual, DerivativeMatchesDifferences) {
  for (double b : {1.0, 4.0}) {
    const CauchyResidual kernel(b);
    for (double d : {-20.0, -3.0, -0.7, -0.2, 0.02, 0.39, 0.41, 1.5, 4.0, 25.0}) {
      double derivative = 0.0;
      kernel(d, &derivative);
      const double h = 1e-6;
      double unused = 0.0;
      const double numeric = (kernel(d + h, &unused) - kernel(d - h, &unused)) / (2.0 * h);
      EXPECT_NEAR(derivative, numeric, 1e-5) << "b " << b << " d " << d;
    }
  }
  double near = 0.0;
  double far = 0.0;
  CauchyResidual(4.0)(0.5, &near);
  CauchyResidual(4.0)(40.0, &far);
  EXPECT_GT(near, 0.9);
  EXPECT_LT(far, 0.1 * near);
}
