// Replays delta-pin's golden vectors through the C library of delta_pin/core/control/ (designs I
// and II on the Delta's analytic nominal model), as a drive would call it: one dp_design_step per
// sample. Checks every torque and rho_hat against the readable Python law's to 1e-12 (relative to
// the largest torque), counts heap allocations during the steps (there must be none), and times
// one step.
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

int main(int argc, char ** argv)
{
  if (argc != 3)
  {
    std::fprintf(stderr, "usage: drive_replay parameters.txt golden.csv\n");
    return 2;
  }
  auto p = read_parameters(argv[1]);
  auto one = [&](const char * name) { return p.at(name).at(0); };
  dp_delta_geometry geometry{one("R"), one("r"), one("l_a"), one("l_b"), one("arm_inertia"), one("arm_gravity"),
                             one("g"), one("m_eq"), {}, {}};
  dp_adaptive_robust_gains gains{};
  dp_friction friction{};
  double disturbance[3];
  for (int i = 0; i < 3; ++i)
  {
    geometry.cos_phi[i] = p.at("cos_phi").at(i);
    geometry.sin_phi[i] = p.at("sin_phi").at(i);
    gains.D[i] = p.at("D").at(i);
    gains.T_p[i] = p.at("T_p").at(i);
    gains.T_v[i] = p.at("T_v").at(i);
    friction.normal_force[i] = p.at("normal_force").at(i);
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
  friction.enabled = (int)one("friction");
  friction.r_a = one("r_a");
  friction.v_s = one("v_s");
  friction.mu_s = one("mu_s");
  friction.mu_d = one("mu_d");
  friction.mu_v = one("mu_v");
  friction.sign_scale = one("sign_scale");
  dp_design * design = dp_design_create(&geometry, &gains, &friction, disturbance, one("period"));
  if (design == nullptr)
  {
    std::fprintf(stderr, "dp_design_create refused the parameters of %s\n", argv[1]);
    return 2;
  }
  std::vector<std::vector<double>> rows;
  {
    std::ifstream file(argv[2]);
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
  }
  double largest_torque = 0.0;
  for (const auto & row : rows)
    for (int i = 15; i < 18; ++i)
      largest_torque = std::max(largest_torque, std::abs(row[i]));
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
  std::printf("samples %zu\n", rows.size());
  std::printf("largest torque error (relative to the largest torque) %.3e\n", worst_tau);
  std::printf("largest rho_hat error (relative) %.3e\n", worst_rho);
  std::printf("heap allocations during the steps %ld\n", during);
  std::printf("time per step %.1f ns\n", 1e9 * seconds / (repeats * (double)rows.size()));
  return (worst_tau <= 1e-12 && worst_rho <= 1e-12 && during == 0) ? 0 : 1;
}
