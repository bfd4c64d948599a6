// Replays delta-pin's golden vectors through the C library of delta_pin/core/control/ (designs I
// and II, or the digital-robust law, on the Delta's analytic nominal model), as a drive would call
// it: one dp_design_step (dp_digital_robust_step) per sample. Checks every torque and rho_hat
// against the readable Python law's to 1e-12 (relative to the largest torque; the digital-robust
// law's torques to 1e-10 over its recursion, see replay_digital_robust), counts heap allocations during the steps
// (there must be none), and times one step.
//
// Run: drive_replay parameters.txt golden.csv

#include "delta_pin_control.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <vector>

static std::atomic<long> allocations{0};

void * operator new(std::size_t size)
{
  ++allocations;
  if (void * memory = std::malloc(size ? size : 1))
    return memory;
  throw std::bad_alloc();
}
void operator delete(void * memory) noexcept { std::free(memory); }
void operator delete(void * memory, std::size_t) noexcept { std::free(memory); }

static std::map<std::string, std::vector<double>> read_parameters(const char * path)
{
  std::map<std::string, std::vector<double>> numbers;
  std::ifstream file(path);
  std::string line;
  while (std::getline(file, line))
  {
    std::istringstream words(line);
    std::string name;
    words >> name;
    double value;
    while (words >> value)
      numbers[name].push_back(value);
  }
  return numbers;
}

typedef std::map<std::string, std::vector<double>> Parameters;
typedef std::vector<std::vector<double>> Rows;

// golden.csv: one row per sample (alpha, alpha_dot, the reference's three, tau, rho_hat)
static Rows read_rows(const char * path)
{
  Rows rows;
  std::ifstream file(path);
  std::string line;
  std::getline(file, line);  // the header
  while (std::getline(file, line))
  {
    std::vector<double> row;
    std::stringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ','))
      row.push_back(std::strtod(cell.c_str(), nullptr));
    rows.push_back(row);
  }
  return rows;
}

static double largest(const Rows & rows)
{
  double torque = 0.0;
  for (const auto & row : rows)
    for (int i = 15; i < 18; ++i)
      torque = std::max(torque, std::abs(row[i]));
  return torque;
}

static dp_delta_geometry geometry_of(const Parameters & p)
{
  auto one = [&](const char * name) { return p.at(name).at(0); };
  dp_delta_geometry geometry{one("R"), one("r"), one("l_a"), one("l_b"), one("arm_inertia"), one("arm_gravity"),
                             one("g"), one("m_eq"), {}, {}};
  for (int i = 0; i < 3; ++i)
  {
    geometry.cos_phi[i] = p.at("cos_phi").at(i);
    geometry.sin_phi[i] = p.at("sin_phi").at(i);
  }
  return geometry;
}

static dp_friction friction_of(const Parameters & p)
{
  auto one = [&](const char * name) { return p.at(name).at(0); };
  dp_friction friction{};
  friction.enabled = (int)one("friction");
  friction.r_a = one("r_a");
  friction.v_s = one("v_s");
  friction.mu_s = one("mu_s");
  friction.mu_d = one("mu_d");
  friction.mu_v = one("mu_v");
  friction.sign_scale = one("sign_scale");
  for (int i = 0; i < 3; ++i)
    friction.normal_force[i] = p.at("normal_force").at(i);
  return friction;
}

static int report(
  size_t samples, double worst_tau, double worst_rho, long during, double seconds_per_step, double torque_tolerance)
{
  std::printf("samples %zu\n", samples);
  std::printf("torque tolerance %.1e\n", torque_tolerance);
  std::printf("largest torque error (relative to the largest torque) %.3e\n", worst_tau);
  std::printf("largest rho_hat error (relative) %.3e\n", worst_rho);
  std::printf("heap allocations during the steps %ld\n", during);
  std::printf("time per step %.1f ns\n", 1e9 * seconds_per_step);
  return (worst_tau <= torque_tolerance && worst_rho <= 1e-12 && during == 0) ? 0 : 1;
}

// the digital-robust law (parameters with "law 2"): the measured angles in, the command out
static int replay_digital_robust(const Parameters & p, const char * golden)
{
  auto one = [&](const char * name) { return p.at(name).at(0); };
  const dp_delta_geometry geometry = geometry_of(p);
  const dp_friction friction = friction_of(p);
  dp_digital_robust_gains gains{};
  gains.period = one("period");
  gains.delay = (int)one("delay");
  gains.K_p = one("K_p");
  gains.K_v = one("K_v");
  gains.D = one("D");
  gains.beta = one("beta");
  gains.b1 = one("b1");
  gains.b2 = one("b2");
  gains.b3 = one("b3");
  gains.epsilon = one("epsilon");
  gains.layer_samples = one("layer_samples");
  gains.rho0 = one("rho0");
  gains.has_limit = (int)one("has_limit");
  gains.observer_size = (int)one("observer_size");
  double disturbance[3];
  for (int i = 0; i < 3; ++i)
  {
    gains.torque_limit[i] = p.at("torque_limit").at(i);
    disturbance[i] = p.at("disturbance").at(i);
  }
  for (int i = 0; i < gains.observer_size; ++i)
  {
    gains.input_gain[i] = p.at("input_gain").at(i);
    gains.observer_gain[i] = p.at("observer_gain").at(i);
    for (int j = 0; j < gains.observer_size; ++j)
      gains.transition[i * gains.observer_size + j] = p.at("transition").at(i * gains.observer_size + j);
  }
  dp_digital_robust * law = dp_digital_robust_create(&geometry, &gains, &friction, disturbance);
  if (law == nullptr)
  {
    std::fprintf(stderr, "dp_digital_robust_create refused the parameters\n");
    return 2;
  }
  const Rows rows = read_rows(golden);
  const double largest_torque = largest(rows);
  double worst_tau = 0.0, worst_rho = 0.0, tau[3];
  const long before = allocations.load();
  for (const auto & row : rows)
  {
    const double rho = dp_digital_robust_rho(law, nullptr);
    worst_rho = std::max(worst_rho, std::abs(rho - row[18]) / std::max(1.0, std::abs(row[18])));
    if (dp_digital_robust_step(law, &row[0], &row[6], &row[9], &row[12], tau) != 0)
    {
      std::fprintf(stderr, "dp_digital_robust_step failed\n");
      return 1;
    }
    for (int i = 0; i < 3; ++i)
      worst_tau = std::max(worst_tau, std::abs(tau[i] - row[15 + i]) / largest_torque);
  }
  const long during = allocations.load() - before;
  const int repeats = 200;
  const auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r)
  {
    dp_digital_robust_reset(law);
    for (const auto & row : rows)
      dp_digital_robust_step(law, &row[0], &row[6], &row[9], &row[12], tau);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  dp_digital_robust_destroy(law);
  // The law is a recursion (the observer's estimate, the commands, M̄ and n̄ at the estimate), and
  // each carries its own: the rounding differences of one sample (~1e-16: LAPACK's solve and
  // eigvalsh and BLAS's products against Eigen's) feed the next. Measured on path I: below 1e-15
  // of the largest torque over the first 1.3 s, then up to ~6e-12 by 2 s, where the observer's
  // five-fold pole at exp(-omega_o T) = 0.86 (an amplification of up to ~1/(1 - 0.86)^5 ~ 2e4)
  // and the nominal friction at the estimated velocity amplify them. 1e-10 bounds that with a
  // margin; the law's arithmetic per sample agrees to ~1e-14 (tests/sim/test_core_laws.py).
  return report(rows.size(), worst_tau, worst_rho, during, seconds / (repeats * (double)rows.size()), 1e-10);
}

int main(int argc, char ** argv)
{
  if (argc != 3)
  {
    std::fprintf(stderr, "usage: drive_replay parameters.txt golden.csv\n");
    return 2;
  }
  const Parameters p = read_parameters(argv[1]);
  if (p.count("law") && p.at("law").at(0) == 2.0)
    return replay_digital_robust(p, argv[2]);
  auto one = [&](const char * name) { return p.at(name).at(0); };
  const dp_delta_geometry geometry = geometry_of(p);
  const dp_friction friction = friction_of(p);
  dp_adaptive_robust_gains gains{};
  double disturbance[3];
  for (int i = 0; i < 3; ++i)
  {
    gains.D[i] = p.at("D").at(i);
    gains.T_p[i] = p.at("T_p").at(i);
    gains.T_v[i] = p.at("T_v").at(i);
    disturbance[i] = p.at("disturbance").at(i);
  }
  gains.beta = one("beta");
  gains.xi = one("xi");
  gains.epsilon = one("epsilon");
  gains.b1 = one("b1");
  gains.b2 = one("b2");
  gains.b3 = one("b3");
  gains.design_two = (int)one("design_two");
  gains.vector_rho = (int)one("vector_rho");
  gains.sampling_period = one("sampling_period");
  gains.sampling_margin = one("sampling_margin");
  gains.rho0 = one("rho0");
  dp_design * design = dp_design_create(&geometry, &gains, &friction, disturbance, one("period"));
  if (design == nullptr)
  {
    std::fprintf(stderr, "dp_design_create refused the parameters of %s\n", argv[1]);
    return 2;
  }
  const Rows rows = read_rows(argv[2]);
  const double largest_torque = largest(rows);
  double worst_tau = 0.0, worst_rho = 0.0;
  double tau[3], rho[3];
  const long before = allocations.load();
  for (const auto & row : rows)
  {
    dp_design_rho(design, rho);
    worst_rho = std::max(worst_rho, std::abs(rho[0] - row[18]) / std::max(1.0, std::abs(row[18])));
    if (dp_design_step(design, &row[0], &row[3], &row[6], &row[9], &row[12], tau) != 0)
    {
      std::fprintf(stderr, "dp_design_step failed\n");
      return 1;
    }
    for (int i = 0; i < 3; ++i)
      worst_tau = std::max(worst_tau, std::abs(tau[i] - row[15 + i]) / largest_torque);
  }
  const long during = allocations.load() - before;
  // time per step: the replay again, repeated
  const int repeats = 200;
  const auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r)
  {
    dp_design_reset(design);
    for (const auto & row : rows)
      dp_design_step(design, &row[0], &row[3], &row[6], &row[9], &row[12], tau);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  dp_design_destroy(design);
  return report(rows.size(), worst_tau, worst_rho, during, seconds / (repeats * (double)rows.size()), 1e-12);
}
