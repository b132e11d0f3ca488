// Timing driver for Pinocchio's C++ (the `pin` wheel's headers and libraries),
// the reference side of benchmarks/bench_codegen.py.
//
//     pinocchio_timing URDF STATES ROUNDS PASSES [DUMP]
//
// Loads URDF with pinocchio::urdf::buildModel, sets the model's gravity and
// armature from the states file (URDF carries neither), and times
// pinocchio::rnea, crba, aba, computeRNEADerivatives and computeABADerivatives on the states of
// STATES (format: states_io.h), every input drawn beforehand by the Python
// side, so that this driver and generated_timing.c time the same inputs.
// Each round times the four calls in a rotated order; ROUNDS rounds; one
// sample is PASSES sweeps over all states.  With DUMP, the answers for every
// state are written there first (tau, M with its lower triangle filled from
// the upper one that crba computes, qdd, dtau/dq, dtau/dqd, ddq_dq, ddq_dv, Minv (both
// triangles); row-major, one
// line each), for the correctness check.
//
// Built by benchmarks/bench_codegen.py (its PINOCCHIO_FLAGS say which flags,
// and why).  Compiled with -DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION, rnea,
// aba and computeRNEADerivatives run the code instantiated inside the wheel's
// libpinocchio_default.so (Pinocchio as shipped, its own build flags); without
// it, every algorithm is instantiated here, with this compilation's flags.
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea-derivatives.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <cstdio>
#include <exception>
#include <vector>

#include "states_io.h"

namespace
{
  using VecMap = Eigen::Map<const Eigen::VectorXd>;

  void write_matrix(FILE * f, const Eigen::MatrixXd & m)
  {
    std::vector<double> row((size_t)(m.rows() * m.cols()));
    for (Eigen::Index r = 0; r < m.rows(); ++r)
      for (Eigen::Index c = 0; c < m.cols(); ++c)
        row[(size_t)(r * m.cols() + c)] = m(r, c);
    md_write_row(f, row.data(), (int)row.size());
  }
} // namespace

int main(int argc, char ** argv)
{
  if (argc != 5 && argc != 6)
  {
    std::fprintf(stderr, "usage: %s URDF STATES ROUNDS PASSES [DUMP]\n", argv[0]);
    return 2;
  }
  int rounds, passes;
  md_parse_counts(argv[3], argv[4], &rounds, &passes);
  md_states s = md_read_states(argv[2]);

  pinocchio::Model model;
  try
  {
    pinocchio::urdf::buildModel(argv[1], model);
  }
  catch (const std::exception & e)
  {
    md_die("Pinocchio cannot build the model from the URDF", e.what());
  }
  if (model.nq != s.n || model.nv != s.n)
    md_die("the URDF's joint count differs from the states file's n", argv[1]);
  model.gravity.linear(Eigen::Vector3d(s.gravity[0], s.gravity[1], s.gravity[2]));
  model.armature = VecMap(s.armature, s.n);
  pinocchio::Data data(model);
  const int n = s.n, k = s.count;
  auto q = [&](int i) { return VecMap(s.q + (size_t)i * n, n); };
  auto qd = [&](int i) { return VecMap(s.qd + (size_t)i * n, n); };
  auto qdd = [&](int i) { return VecMap(s.qdd + (size_t)i * n, n); };
  auto tau = [&](int i) { return VecMap(s.tau + (size_t)i * n, n); };

  if (argc == 6)
  {
    FILE * f = std::fopen(argv[5], "w");
    if (!f)
      md_die("cannot write", argv[5]);
    for (int i = 0; i < k; ++i)
    {
      Eigen::VectorXd t = pinocchio::rnea(model, data, q(i), qd(i), qdd(i));
      md_write_row(f, t.data(), n);
      pinocchio::crba(model, data, q(i));
      data.M.triangularView<Eigen::StrictlyLower>() = data.M.transpose().triangularView<Eigen::StrictlyLower>();
      write_matrix(f, data.M);
      Eigen::VectorXd a = pinocchio::aba(model, data, q(i), qd(i), tau(i));
      md_write_row(f, a.data(), n);
      pinocchio::computeRNEADerivatives(model, data, q(i), qd(i), qdd(i));
      write_matrix(f, data.dtau_dq);
      write_matrix(f, data.dtau_dv);
      pinocchio::computeABADerivatives(model, data, q(i), qd(i), tau(i));
      data.Minv.triangularView<Eigen::StrictlyLower>() = data.Minv.transpose().triangularView<Eigen::StrictlyLower>();
      write_matrix(f, data.ddq_dq);
      write_matrix(f, data.ddq_dv);
      write_matrix(f, data.Minv);
    }
    if (std::fclose(f) != 0)
      md_die("cannot write", argv[5]);
  }

  std::vector<double> samples[MD_NOPS];
  volatile double sink = 0.0;   // keeps every call's result alive
  for (int r = 0; r < rounds; ++r)
  {
    std::printf("round %d", r);
    double ns[MD_NOPS];
    for (int j = 0; j < MD_NOPS; ++j)
    {
      const int op = (r + j) % MD_NOPS;
      double acc = 0.0;
      const double t0 = md_now_ns();
      for (int p = 0; p < passes; ++p)
        for (int i = 0; i < k; ++i)
          switch (op)
          {
          case 0:
            acc += pinocchio::rnea(model, data, q(i), qd(i), qdd(i))[0];
            break;
          case 1:
            acc += pinocchio::crba(model, data, q(i))(0, n - 1);
            break;
          case 2:
            acc += pinocchio::aba(model, data, q(i), qd(i), tau(i))[0];
            break;
          case 3:
            pinocchio::computeRNEADerivatives(model, data, q(i), qd(i), qdd(i));
            acc += data.dtau_dq(0, 0);
            break;
          default:
            pinocchio::computeABADerivatives(model, data, q(i), qd(i), tau(i));
            acc += data.ddq_dq(0, 0);
          }
      ns[op] = (md_now_ns() - t0) / ((double)passes * k);
      sink = sink + acc;
    }
    for (int op = 0; op < MD_NOPS; ++op)
    {
      samples[op].push_back(ns[op]);
      std::printf(" %s %.3f", md_op_names[op], ns[op]);
    }
    std::printf("\n");
  }
  std::printf("median");
  for (int op = 0; op < MD_NOPS; ++op)
    std::printf(" %s %.3f", md_op_names[op], md_median(samples[op].data(), rounds));
  std::printf("\n");
#ifdef PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION
  std::printf("info pinocchio %s instantiation library\n", PINOCCHIO_VERSION);
#else
  std::printf("info pinocchio %s instantiation header\n", PINOCCHIO_VERSION);
#endif
  return sink == 12345.678 ? 1 : 0;   // never: only makes the sink observable
}
