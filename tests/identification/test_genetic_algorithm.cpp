// The GA of Table 7 (genetic_algorithm.hpp): deterministic for a seed whatever the batch
// evaluation's threading, different for another seed, converging on a known minimum.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <thread>

#include "hexa/core/genetic_algorithm.hpp"

namespace hexa {
namespace {

double Sphere(const Genome& g) {
  // Minimum 0 at (0.3, 0.7, 0.1, 0.9, 0.5, 0.2, 0.6), inside [0, 1]^7.
  static const double kCentre[] = {0.3, 0.7, 0.1, 0.9, 0.5, 0.2, 0.6};
  double s = 0.0;
  for (std::size_t i = 0; i < g.size(); ++i) s += (g[i] - kCentre[i]) * (g[i] - kCentre[i]);
  return std::sqrt(s);
}

GaBatchCost Sequential() {
  return [](const std::vector<Genome>& g, std::vector<double>& c) {
    for (std::size_t i = 0; i < g.size(); ++i) c[i] = Sphere(g[i]);
  };
}

GaBatchCost TwoThreads() {
  return [](const std::vector<Genome>& g, std::vector<double>& c) {
    std::thread t([&] {
      for (std::size_t i = 1; i < g.size(); i += 2) c[i] = Sphere(g[i]);
    });
    for (std::size_t i = 0; i < g.size(); i += 2) c[i] = Sphere(g[i]);
    t.join();
  };
}

TEST(GeneticAlgorithm, Table7DefaultsAndOffspringCounts) {
  const GaParams p;
  EXPECT_EQ(p.num_variables, 7);
  EXPECT_EQ(p.max_iterations, 1000);
  EXPECT_EQ(p.population, 100);
  EXPECT_EQ(p.crossover_fraction, 0.8);
  EXPECT_EQ(p.mutation_fraction, 0.3);
  EXPECT_EQ(p.mutation_rate, 0.02);
  GaParams q = p;
  q.max_iterations = 3;
  const GaResult r = RunGeneticAlgorithm(q, Sequential());
  // 100 initial + 3 x (80 crossover offspring + 30 mutants).
  EXPECT_EQ(r.evaluations, 100u + 3u * 110u);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_EQ(r.best_cost_history.size(), 4u);
}

TEST(GeneticAlgorithm, DeterministicForASeedWhateverTheThreads) {
  GaParams p;
  p.max_iterations = 40;
  p.seed = 17;
  const GaResult a = RunGeneticAlgorithm(p, Sequential());
  const GaResult b = RunGeneticAlgorithm(p, TwoThreads());
  ASSERT_EQ(a.best.size(), 7u);
  EXPECT_EQ(a.best, b.best);  // bit for bit
  EXPECT_EQ(a.best_cost, b.best_cost);
  EXPECT_EQ(a.best_cost_history, b.best_cost_history);
  p.seed = 18;
  const GaResult c = RunGeneticAlgorithm(p, Sequential());
  EXPECT_NE(a.best, c.best);
}

TEST(GeneticAlgorithm, ConvergesOnAKnownMinimumAndNeverGetsWorse) {
  GaParams p;
  p.max_iterations = 150;
  const GaResult r = RunGeneticAlgorithm(p, Sequential());
  EXPECT_LT(r.best_cost, 0.02);
  for (std::size_t k = 1; k < r.best_cost_history.size(); ++k) {
    EXPECT_LE(r.best_cost_history[k], r.best_cost_history[k - 1]);  // elitist
  }
  for (double g : r.best) {
    EXPECT_GE(g, 0.0);
    EXPECT_LE(g, 1.0);
  }
}

// A correlated flat valley like the friction parameters' (docs/identification.md, "Why the
// template GA stalls"): genes 0-3 enter mostly through one combination, so Z rises steeply
// across the valley and slowly (curvature 4e-3, a curvature ratio of 250 as F_c's alone /
// profile at leg 1 extend) along its direction (0.5, -0.5, 0.5, 0.5); genes 4-6 are a plain
// bowl. Z = sqrt of the quadratic, as eq 13.
const double kValleyOptimum[] = {0.35, 0.6, 0.45, 0.55, 0.5, 0.3, 0.7};
double Valley(const Genome& g) {
  static const double kAlong[] = {0.5, -0.5, 0.5, 0.5};
  double d[7];
  for (int i = 0; i < 7; ++i) d[i] = g[static_cast<std::size_t>(i)] - kValleyOptimum[i];
  double along = 0.0;
  for (int i = 0; i < 4; ++i) along += kAlong[i] * d[i];
  double across = 0.0;  // |d_0..3 - along * kAlong|^2
  for (int i = 0; i < 4; ++i) across += (d[i] - along * kAlong[i]) * (d[i] - along * kAlong[i]);
  double bowl = 0.0;
  for (int i = 4; i < 7; ++i) bowl += d[i] * d[i];
  return std::sqrt(across + 4e-3 * along * along + bowl);
}

double DistanceToValleyOptimum(const Genome& g) {
  double s = 0.0;
  for (int i = 0; i < 7; ++i) s += (g[static_cast<std::size_t>(i)] - kValleyOptimum[i]) * (g[static_cast<std::size_t>(i)] - kValleyOptimum[i]);
  return std::sqrt(s);
}

GaResult RunOnValley(GaParams p) {
  return RunGeneticAlgorithm(p, [](const std::vector<Genome>& g, std::vector<double>& c) {
    for (std::size_t i = 0; i < g.size(); ++i) c[i] = Valley(g[i]);
  });
}

// What was measured (docs/identification.md): with Table 7's settings (MaxIt 1000, nPop 100,
// pc 0.8, pm 0.3, mu 0.02) the template GA stalls in the valley, 0.1 of the gene range
// from the optimum (the population collapses onto one point, then only one-gene steps of
// sigma 0.1 move it); the 1/5 success rule on the step lets it creep along the valley and
// ends nearer, but NOT at the optimum (0.06-0.10). This test pins both facts; it is not a
// test that the GA reaches the optimum, which none of the variants tried does.
TEST(GeneticAlgorithm, Table7StallsInACorrelatedFlatValleyAndTheSuccessRuleCreepsOn) {
  double sum_old = 0.0, sum_rule = 0.0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    GaParams p;  // Table 7, template operators
    p.seed = seed;
    const GaResult old = RunOnValley(p);
    p.mutation_step = GaParams::MutationStep::kSuccessRule;
    const GaResult r = RunOnValley(p);
    std::printf("seed %llu: distance to the optimum, template %.3e, success rule %.3e\n",
                static_cast<unsigned long long>(seed), DistanceToValleyOptimum(old.best),
                DistanceToValleyOptimum(r.best));
    EXPECT_GT(DistanceToValleyOptimum(old.best), 0.05) << "seed " << seed;
    EXPECT_LT(DistanceToValleyOptimum(r.best), DistanceToValleyOptimum(old.best)) << "seed " << seed;
    EXPECT_GT(DistanceToValleyOptimum(r.best), 0.01) << "seed " << seed << ": reaches the optimum now; update the docs";
    sum_old += DistanceToValleyOptimum(old.best);
    sum_rule += DistanceToValleyOptimum(r.best);
    for (std::size_t k = 1; k < r.best_cost_history.size(); ++k) {
      EXPECT_LE(r.best_cost_history[k], r.best_cost_history[k - 1]);  // still elitist
    }
  }
  EXPECT_LT(sum_rule, 0.8 * sum_old);
}

TEST(GeneticAlgorithm, DeterministicForASeedWithTheOptionalOperators) {
  GaParams p;
  p.max_iterations = 60;
  p.seed = 17;
  p.crossover_per_pair = true;
  p.mutation_step = GaParams::MutationStep::kSuccessRule;
  const GaResult a = RunGeneticAlgorithm(p, Sequential());
  const GaResult b = RunGeneticAlgorithm(p, TwoThreads());
  EXPECT_EQ(a.best, b.best);  // bit for bit
  EXPECT_EQ(a.best_cost_history, b.best_cost_history);
  p.seed = 18;
  EXPECT_NE(RunGeneticAlgorithm(p, Sequential()).best, a.best);
}

TEST(GeneticAlgorithm, ProgressCanStopTheRun) {
  GaParams p;
  int calls = 0;
  const GaResult r = RunGeneticAlgorithm(p, Sequential(), [&](const GaProgress& g) {
    ++calls;
    return g.iteration < 5;
  });
  EXPECT_EQ(r.iterations, 5);
  EXPECT_EQ(calls, 6);
}

}  // namespace
}  // namespace hexa
