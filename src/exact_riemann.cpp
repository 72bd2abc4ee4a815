#include "exact_riemann.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mpmflow {

ExactRiemannSolver::ExactRiemannSolver(const PrimitiveState1D& left, const PrimitiveState1D& right, double gamma)
    : left_(left), right_(right), gamma_(gamma) {
  c_left_ = std::sqrt(gamma * left.pressure / left.density);
  c_right_ = std::sqrt(gamma * right.pressure / right.density);
  if (2 * (c_left_ + c_right_) / (gamma - 1) <= right.velocity - left.velocity)
    throw std::invalid_argument("exact Riemann solver: the initial data generate a vacuum");

  // Two-rarefaction guess (Toro eq. 4.46), robust for all but near-vacuum data.
  const double z = (gamma - 1) / (2 * gamma);
  double p = std::pow((c_left_ + c_right_ - 0.5 * (gamma - 1) * (right.velocity - left.velocity)) /
                          (c_left_ / std::pow(left.pressure, z) + c_right_ / std::pow(right.pressure, z)),
                      1 / z);
  p = std::max(p, 1e-12);
  for (int iteration = 0; iteration < 100; ++iteration) {
    double fl, dfl, fr, dfr;
    pressure_function(p, left_, c_left_, fl, dfl);
    pressure_function(p, right_, c_right_, fr, dfr);
    const double p_new = std::max(p - (fl + fr + right.velocity - left.velocity) / (dfl + dfr), 1e-12);
    const double change = 2 * std::fabs(p_new - p) / (p_new + p);
    p = p_new;
    if (change < 1e-14) break;
  }
  double fl, dfl, fr, dfr;
  pressure_function(p, left_, c_left_, fl, dfl);
  pressure_function(p, right_, c_right_, fr, dfr);
  p_star_ = p;
  u_star_ = 0.5 * (left.velocity + right.velocity) + 0.5 * (fr - fl);
}

void ExactRiemannSolver::pressure_function(double p, const PrimitiveState1D& side, double c, double& f,
                                           double& df) const {
  const double g = gamma_;
  if (p > side.pressure) {  // shock
    const double a = 2 / ((g + 1) * side.density);
    const double b = (g - 1) / (g + 1) * side.pressure;
    const double root = std::sqrt(a / (b + p));
    f = (p - side.pressure) * root;
    df = root * (1 - 0.5 * (p - side.pressure) / (b + p));
  } else {  // rarefaction
    const double ratio = p / side.pressure;
    f = 2 * c / (g - 1) * (std::pow(ratio, (g - 1) / (2 * g)) - 1);
    df = 1 / (side.density * c) * std::pow(ratio, -(g + 1) / (2 * g));
  }
}

double ExactRiemannSolver::star_density_left() const {
  const double g = gamma_, ratio = p_star_ / left_.pressure;
  if (p_star_ > left_.pressure)
    return left_.density * (ratio + (g - 1) / (g + 1)) / ((g - 1) / (g + 1) * ratio + 1);
  return left_.density * std::pow(ratio, 1 / g);
}

double ExactRiemannSolver::star_density_right() const {
  const double g = gamma_, ratio = p_star_ / right_.pressure;
  if (p_star_ > right_.pressure)
    return right_.density * (ratio + (g - 1) / (g + 1)) / ((g - 1) / (g + 1) * ratio + 1);
  return right_.density * std::pow(ratio, 1 / g);
}

double ExactRiemannSolver::right_wave_speed() const {
  const double g = gamma_;
  if (p_star_ > right_.pressure)
    return right_.velocity +
           c_right_ * std::sqrt((g + 1) / (2 * g) * p_star_ / right_.pressure + (g - 1) / (2 * g));
  return right_.velocity + c_right_;
}

double ExactRiemannSolver::left_wave_speed() const {
  const double g = gamma_;
  if (p_star_ > left_.pressure)
    return left_.velocity - c_left_ * std::sqrt((g + 1) / (2 * g) * p_star_ / left_.pressure + (g - 1) / (2 * g));
  return left_.velocity - c_left_;
}

PrimitiveState1D ExactRiemannSolver::sample(double s) const {
  const double g = gamma_;
  if (s <= u_star_) {  // left of the contact
    if (p_star_ > left_.pressure) {
      return s <= left_wave_speed() ? left_ : PrimitiveState1D{star_density_left(), u_star_, p_star_};
    }
    const double head = left_.velocity - c_left_;
    const double c_star = c_left_ * std::pow(p_star_ / left_.pressure, (g - 1) / (2 * g));
    const double tail = u_star_ - c_star;
    if (s <= head) return left_;
    if (s >= tail) return {star_density_left(), u_star_, p_star_};
    // inside the left rarefaction fan (Toro eq. 4.56)
    const double c = 2 / (g + 1) * (c_left_ + 0.5 * (g - 1) * (left_.velocity - s));
    const double u = 2 / (g + 1) * (c_left_ + 0.5 * (g - 1) * left_.velocity + s);
    const double rho = left_.density * std::pow(c / c_left_, 2 / (g - 1));
    return {rho, u, left_.pressure * std::pow(c / c_left_, 2 * g / (g - 1))};
  }
  if (p_star_ > right_.pressure) {
    return s >= right_wave_speed() ? right_ : PrimitiveState1D{star_density_right(), u_star_, p_star_};
  }
  const double head = right_.velocity + c_right_;
  const double c_star = c_right_ * std::pow(p_star_ / right_.pressure, (g - 1) / (2 * g));
  const double tail = u_star_ + c_star;
  if (s >= head) return right_;
  if (s <= tail) return {star_density_right(), u_star_, p_star_};
  const double c = 2 / (g + 1) * (c_right_ - 0.5 * (g - 1) * (right_.velocity - s));
  const double u = 2 / (g + 1) * (-c_right_ + 0.5 * (g - 1) * right_.velocity + s);
  const double rho = right_.density * std::pow(c / c_right_, 2 / (g - 1));
  return {rho, u, right_.pressure * std::pow(c / c_right_, 2 * g / (g - 1))};
}

}  // namespace mpmflow
