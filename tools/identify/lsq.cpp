#include "lsq.hpp"

#include <ceres/ceres.h>

#include <chrono>
#include <cmath>
#include <vector>

namespace hexa::identify {
namespace {

// All residuals of one dataset in one block of 7 parameters (Table 8 order), with the
// analytic Jacobian of StrokeDataset::Residuals.
class StrokeCost final : public ceres::CostFunction {
 public:
  explicit StrokeCost(const StrokeDataset& data) : data_(data) {
    set_num_residuals(static_cast<int>(data.samples.size() + 6));
    mutable_parameter_block_sizes()->push_back(StrokeParams::kCount);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    StrokeParams::Vector v;
    for (int i = 0; i < StrokeParams::kCount; ++i) v[i] = parameters[0][i];
    const StrokeParams p = StrokeParams::FromVector(v);
    if (!(p.stribeck_velocity_m_s > 0.0) || !v.allFinite()) return false;
    const bool want_j = jacobians != nullptr && jacobians[0] != nullptr;
    data_.Residuals(p, r_, want_j ? &J_ : nullptr);
    for (Eigen::Index k = 0; k < r_.size(); ++k) residuals[k] = r_[k];
    if (want_j) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, StrokeParams::kCount, Eigen::RowMajor>>(
          jacobians[0], J_.rows(), StrokeParams::kCount) = J_;
    }
    return true;
  }

 private:
  const StrokeDataset& data_;
  mutable Eigen::VectorXd r_;
  mutable Eigen::MatrixXd J_;
};

// Acceleration residuals of both directions; parameters [s, ext(v_s, B, F_s, F_c), ret(...)].
class PayloadCost final : public ceres::CostFunction {
 public:
  PayloadCost(const StrokeDataset& extend, const StrokeDataset& retract) : ext_(extend), ret_(retract) {
    set_num_residuals(static_cast<int>(extend.samples.size() + retract.samples.size()));
    mutable_parameter_block_sizes()->push_back(9);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* q = parameters[0];
    const double s = q[0];
    const FrictionDirectionParams fe{q[1], q[2], q[3], q[4]};
    const FrictionDirectionParams fr{q[5], q[6], q[7], q[8]};
    if (!(s > 0.0) || !(fe.stribeck_velocity_m_s > 0.0) || !(fr.stribeck_velocity_m_s > 0.0)) return false;
    const std::size_t ne = ext_.samples.size(), nr = ret_.samples.size();
    const bool want_j = jacobians != nullptr && jacobians[0] != nullptr;
    j_.resize(5 * std::max(ne, nr));
    ext_.AccelResiduals(s, fe, residuals, want_j ? j_.data() : nullptr);
    if (want_j) {
      for (std::size_t k = 0; k < ne; ++k) {
        double* row = jacobians[0] + 9 * k;
        row[0] = j_[5 * k];
        for (int c = 0; c < 4; ++c) row[1 + c] = j_[5 * k + 1 + c];
        for (int c = 0; c < 4; ++c) row[5 + c] = 0.0;
      }
    }
    ret_.AccelResiduals(s, fr, residuals + ne, want_j ? j_.data() : nullptr);
    if (want_j) {
      for (std::size_t k = 0; k < nr; ++k) {
        double* row = jacobians[0] + 9 * (ne + k);
        row[0] = j_[5 * k];
        for (int c = 0; c < 4; ++c) row[1 + c] = 0.0;
        for (int c = 0; c < 4; ++c) row[5 + c] = j_[5 * k + 1 + c];
      }
    }
    return true;
  }

 private:
  const StrokeDataset& ext_;
  const StrokeDataset& ret_;
  mutable std::vector<double> j_;
};

ceres::Solver::Options Options() {
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = 200;
  o.function_tolerance = 1e-12;
  o.gradient_tolerance = 1e-12;
  o.parameter_tolerance = 1e-12;
  o.num_threads = 1;
  o.logging_type = ceres::SILENT;
  return o;
}

}  // namespace

LsqResult FitStrokeLeastSquares(const StrokeDataset& data, const StrokeParams& start) {
  const auto t0 = std::chrono::steady_clock::now();
  LsqResult result;
  StrokeParams::Vector x = start.ToVector();
  double block[StrokeParams::kCount];
  for (int i = 0; i < StrokeParams::kCount; ++i) block[i] = x[i];
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddResidualBlock(new StrokeCost(data), nullptr, block);
  problem.SetParameterLowerBound(block, 0, 1e-3);  // v_s: eq 3 divides by it
  ceres::Solver::Summary summary;
  ceres::Solve(Options(), &problem, &summary);
  for (int i = 0; i < StrokeParams::kCount; ++i) x[i] = block[i];
  result.params = StrokeParams::FromVector(x);
  result.objective = data.Nrmse(result.params);
  result.initial_objective = data.Nrmse(start);
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.summary = summary.BriefReport();
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

PayloadResult FitPayloadScale(const StrokeDataset& extend, const StrokeDataset& retract,
                              const FrictionDirectionParams& e, const FrictionDirectionParams& r) {
  double q[9] = {1.0,
                 e.stribeck_velocity_m_s, e.viscous_n_s_m, e.static_n, e.coulomb_n,
                 r.stribeck_velocity_m_s, r.viscous_n_s_m, r.static_n, r.coulomb_n};
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddResidualBlock(new PayloadCost(extend, retract), nullptr, q);
  problem.SetParameterLowerBound(q, 0, 0.05);
  problem.SetParameterLowerBound(q, 1, 1e-3);
  problem.SetParameterLowerBound(q, 5, 1e-3);
  ceres::Solver::Summary summary;
  ceres::Solve(Options(), &problem, &summary);
  PayloadResult p;
  p.payload_scale = q[0];
  p.friction[0] = FrictionDirectionParams{q[1], q[2], q[3], q[4]};
  p.friction[1] = FrictionDirectionParams{q[5], q[6], q[7], q[8]};
  p.objective = std::sqrt(2.0 * summary.final_cost);
  p.converged = summary.termination_type == ceres::CONVERGENCE;
  return p;
}

}  // namespace hexa::identify
