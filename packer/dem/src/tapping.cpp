// Tapping: the container's vertical lift as a function of time (one sine period per tap,
// then a rest).
#include <algorithm>
#include <cmath>

#include "system_impl.hpp"

namespace voxpack::packer::dem {

double DemSystem::Impl::wallOffset(double time, double* velocity) const {
  if (velocity) *velocity = 0;
  if (tapCycles <= 0 || time < tapStart) return 0;
  const double f = opt.tapFrequencyHz;
  const double period = 1.0 / f + opt.tapRestS;
  const double tau = time - tapStart;
  const int cycle = static_cast<int>(std::floor(tau / period));
  if (cycle >= tapCycles) return 0;
  const double local = tau - cycle * period;
  if (local >= 1.0 / f) return 0;
  const double a = tapAmplitude();
  const double w = 2 * kPi * f;
  // Smooth lift and return: z = A/2 (1 - cos wt); peak acceleration A/2 w^2.
  if (velocity) *velocity = 0.5 * a * w * std::sin(w * local);
  return 0.5 * a * (1 - std::cos(w * local));
}

double DemSystem::Impl::tapAmplitude() const {
  return opt.tapAmplitudeMm > 0 ? opt.tapAmplitudeMm : 0.3 * dMin();
}

double DemSystem::Impl::tapEnd() const {
  return tapStart + tapCycles * (1.0 / opt.tapFrequencyHz + opt.tapRestS);
}

// Inside the lift of a tap (not its rest).
bool DemSystem::Impl::wallLiftingAt(double time) const {
  if (!wallMovingAt(time)) return false;
  const double period = 1.0 / opt.tapFrequencyHz + opt.tapRestS;
  const double local = std::fmod(time - tapStart, period);
  return local < 1.0 / opt.tapFrequencyHz;
}

bool DemSystem::Impl::wallMovingAt(double time) const {
  return tapCycles > 0 && time >= tapStart && time < tapEnd();
}

}  // namespace voxpack::packer::dem
