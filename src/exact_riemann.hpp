#pragma once
// Exact solution of the Riemann problem for the 1D Euler equations of a perfect gas
// (Toro, "Riemann Solvers and Numerical Methods for Fluid Dynamics", ch. 4): the star-region
// pressure by Newton iteration on the pressure function, then sampling of the self-similar wave
// pattern. Used to verify the solver (Sod) and by the plotting tools.
namespace mpmflow {

struct PrimitiveState1D {
  double density = 0;
  double velocity = 0;
  double pressure = 0;
};

class ExactRiemannSolver {
 public:
  ExactRiemannSolver(const PrimitiveState1D& left, const PrimitiveState1D& right, double gamma);

  double star_pressure() const { return p_star_; }
  double star_velocity() const { return u_star_; }
  double star_density_left() const;
  double star_density_right() const;

  // The state at x / t = speed (the diaphragm at speed 0).
  PrimitiveState1D sample(double speed) const;
  // The state at position x at time t for a diaphragm at x0.
  PrimitiveState1D solution(double x, double t, double x0) const {
    return t > 0 ? sample((x - x0) / t) : (x < x0 ? left_ : right_);
  }

  // Speeds of the leading waves: shock speed (or rarefaction head) on each side.
  double right_wave_speed() const;
  double left_wave_speed() const;

 private:
  // f_K(p) and its derivative (Toro eqs. 4.6-4.7) for side K.
  void pressure_function(double p, const PrimitiveState1D& side, double c, double& f, double& df) const;

  PrimitiveState1D left_, right_;
  double gamma_;
  double c_left_, c_right_;
  double p_star_ = 0, u_star_ = 0;
};

}  // namespace mpmflow
