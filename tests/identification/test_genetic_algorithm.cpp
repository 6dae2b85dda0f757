// The GA of Table 7 (genetic_algorithm.hpp): deterministic for a seed whatever the batch
// evaluation's threading, different for another seed, converging on a known minimum.
#include <gtest/gtest.h>

#include <cmath>
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
