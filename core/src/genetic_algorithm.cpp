#include "hexa/core/genetic_algorithm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>

namespace hexa {
namespace {

void Require(bool ok, const char* field, double value, const char* limit) {
  if (ok) return;
  std::ostringstream m;
  m << "genetic algorithm: " << field << " = " << value << " must be " << limit;
  throw std::invalid_argument(m.str());
}

// Portable random numbers: the same sequence with any standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  int Index(int n) {  // [0, n)
    return std::min(n - 1, static_cast<int>(Uniform() * n));
  }
  double Normal() {  // Box-Muller, one value per call (the pair's second is dropped)
    double u1 = Uniform();
    while (u1 <= 0.0) u1 = Uniform();
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
  }

 private:
  std::mt19937_64 engine_;
};

struct Individual {
  Genome genes;
  double cost = 0.0;
};

double Sanitise(double cost) {
  return std::isfinite(cost) && cost >= 0.0 ? cost : std::numeric_limits<double>::max();
}

}  // namespace

void GaParams::Validate() const {
  Require(num_variables >= 1, "num_variables (nVar)", num_variables, ">= 1");
  Require(std::isfinite(var_min) && std::isfinite(var_max) && var_max > var_min, "var_max (VarMax)",
          var_max, "finite and > var_min (VarMin)");
  Require(max_iterations >= 0, "max_iterations (MaxIt)", max_iterations, ">= 0");
  Require(population >= 2, "population (nPop)", population, ">= 2");
  Require(crossover_fraction >= 0.0 && crossover_fraction <= 2.0, "crossover_fraction (pc)",
          crossover_fraction, "in [0, 2]");
  Require(mutation_fraction >= 0.0 && mutation_fraction <= 2.0, "mutation_fraction (pm)",
          mutation_fraction, "in [0, 2]");
  Require(mutation_rate >= 0.0 && mutation_rate <= 1.0, "mutation_rate (mu)", mutation_rate,
          "in [0, 1]");
  Require(crossover_gamma >= 0.0 && std::isfinite(crossover_gamma), "crossover_gamma",
          crossover_gamma, "finite and >= 0");
  Require(mutation_sigma_fraction > 0.0 && std::isfinite(mutation_sigma_fraction),
          "mutation_sigma_fraction", mutation_sigma_fraction, "finite and > 0");
  Require(selection_pressure >= 0.0 && std::isfinite(selection_pressure), "selection_pressure",
          selection_pressure, "finite and >= 0");
  Require(success_rule_factor > 0.0 && success_rule_factor < 1.0, "success_rule_factor",
          success_rule_factor, "in (0, 1)");
  Require(mutation_sigma_floor > 0.0 && mutation_sigma_floor <= mutation_sigma_fraction,
          "mutation_sigma_floor", mutation_sigma_floor, "> 0 and <= mutation_sigma_fraction");
}

GaResult RunGeneticAlgorithm(const GaParams& p, const GaBatchCost& cost,
                             const GaProgressFn& progress) {
  p.Validate();
  Random random(p.seed);
  const int n_var = p.num_variables;
  const int n_pop = p.population;
  const int n_crossover = 2 * static_cast<int>(std::lround(p.crossover_fraction * n_pop / 2.0));
  const int n_mutation = static_cast<int>(std::lround(p.mutation_fraction * n_pop));
  const int genes_mutated =
      std::min(n_var, std::max(p.mutation_rate > 0.0 ? 1 : 0,
                               static_cast<int>(std::ceil(p.mutation_rate * n_var))));
  const double sigma = p.mutation_sigma_fraction * (p.var_max - p.var_min);
  const double sigma_floor = p.mutation_sigma_floor * (p.var_max - p.var_min);
  std::vector<double> sigma_gene(static_cast<std::size_t>(n_var), sigma);
  std::vector<double> spread(static_cast<std::size_t>(n_var), 0.0);
  auto measure_spread = [&](const std::vector<Individual>& pop) {
    for (int j = 0; j < n_var; ++j) {
      double lo = pop.front().genes[static_cast<std::size_t>(j)], hi = lo;
      for (const Individual& ind : pop) {
        lo = std::min(lo, ind.genes[static_cast<std::size_t>(j)]);
        hi = std::max(hi, ind.genes[static_cast<std::size_t>(j)]);
      }
      spread[static_cast<std::size_t>(j)] = hi - lo;
    }
  };
  double selection_ratio = 1.0;
  std::vector<double> mutant_parent_cost;
  auto clamp = [&](double v) { return std::clamp(v, p.var_min, p.var_max); };

  std::vector<Genome> batch;
  std::vector<double> costs;
  GaResult result;
  auto evaluate = [&](std::vector<Individual>& out) {
    costs.assign(batch.size(), 0.0);
    if (!batch.empty()) cost(batch, costs);
    result.evaluations += batch.size();
    for (std::size_t i = 0; i < batch.size(); ++i) {
      out.push_back(Individual{std::move(batch[i]), Sanitise(costs[i])});
    }
    batch.clear();
  };
  auto by_cost = [](const Individual& a, const Individual& b) { return a.cost < b.cost; };

  // Initial population, uniform in [VarMin, VarMax].
  std::vector<Individual> pop;
  pop.reserve(static_cast<std::size_t>(n_pop + n_crossover + n_mutation));
  for (int i = 0; i < n_pop; ++i) {
    Genome g(static_cast<std::size_t>(n_var));
    for (double& v : g) v = random.Uniform(p.var_min, p.var_max);
    batch.push_back(std::move(g));
  }
  evaluate(pop);
  std::stable_sort(pop.begin(), pop.end(), by_cost);
  double worst = pop.back().cost;
  auto report = [&](int iteration) {
    double mean = 0.0;
    for (const Individual& ind : pop) mean += ind.cost;
    mean /= static_cast<double>(pop.size());
    result.best_cost_history.push_back(pop.front().cost);
    if (!progress) return true;
    measure_spread(pop);
    GaProgress g;
    g.iteration = iteration;
    g.best_cost = pop.front().cost;
    g.mean_cost = mean;
    g.evaluations = result.evaluations;
    g.max_gene_spread = *std::max_element(spread.begin(), spread.end());
    g.selection_ratio = selection_ratio;
    return progress(g);
  };
  bool go_on = report(0);

  std::vector<double> probability(static_cast<std::size_t>(n_pop));
  for (int it = 1; it <= p.max_iterations && go_on; ++it) {
    // Roulette-wheel probabilities exp(-beta cost / worst cost).
    const double scale = worst > 0.0 && worst < std::numeric_limits<double>::max() ? worst : 1.0;
    double total = 0.0;
    for (int i = 0; i < n_pop; ++i) {
      probability[static_cast<std::size_t>(i)] =
          std::exp(-p.selection_pressure * pop[static_cast<std::size_t>(i)].cost / scale);
      total += probability[static_cast<std::size_t>(i)];
    }
    selection_ratio = probability.front() / std::max(probability.back(), std::numeric_limits<double>::min());
    auto roulette = [&]() {
      const double r = random.Uniform() * total;
      double c = 0.0;
      for (int i = 0; i < n_pop; ++i) {
        c += probability[static_cast<std::size_t>(i)];
        if (r < c) return i;
      }
      return n_pop - 1;
    };
    // Crossover: nc offspring from nc / 2 parent pairs.
    for (int k = 0; k < n_crossover / 2; ++k) {
      const Genome& x1 = pop[static_cast<std::size_t>(roulette())].genes;
      const Genome& x2 = pop[static_cast<std::size_t>(roulette())].genes;
      Genome y1(x1.size()), y2(x1.size());
      const double a_pair = p.crossover_per_pair ? random.Uniform(-p.crossover_gamma, 1.0 + p.crossover_gamma) : 0.0;
      for (std::size_t j = 0; j < x1.size(); ++j) {
        const double a = p.crossover_per_pair ? a_pair : random.Uniform(-p.crossover_gamma, 1.0 + p.crossover_gamma);
        y1[j] = clamp(a * x1[j] + (1.0 - a) * x2[j]);
        y2[j] = clamp(a * x2[j] + (1.0 - a) * x1[j]);
      }
      batch.push_back(std::move(y1));
      batch.push_back(std::move(y2));
    }
    // Mutation: nm mutants of random members.
    if (p.mutation_step == GaParams::MutationStep::kPopulationSpread) {
      measure_spread(pop);
      for (int j = 0; j < n_var; ++j) {
        sigma_gene[static_cast<std::size_t>(j)] =
            std::clamp(p.mutation_sigma_fraction * spread[static_cast<std::size_t>(j)], sigma_floor, sigma);
      }
    }
    mutant_parent_cost.clear();
    for (int k = 0; k < n_mutation; ++k) {
      const auto parent = static_cast<std::size_t>(random.Index(n_pop));
      mutant_parent_cost.push_back(pop[parent].cost);
      Genome y = pop[parent].genes;
      // ceil(mu nVar) distinct genes (partial Fisher-Yates).
      std::vector<int> order(static_cast<std::size_t>(n_var));
      std::iota(order.begin(), order.end(), 0);
      for (int m = 0; m < genes_mutated; ++m) {
        const int pick = m + random.Index(n_var - m);
        std::swap(order[static_cast<std::size_t>(m)], order[static_cast<std::size_t>(pick)]);
        const auto j = static_cast<std::size_t>(order[static_cast<std::size_t>(m)]);
        y[j] = clamp(y[j] + sigma_gene[j] * random.Normal());
      }
      batch.push_back(std::move(y));
    }
    evaluate(pop);  // appended to the parents
    if (p.mutation_step == GaParams::MutationStep::kSuccessRule && n_mutation > 0) {
      int better = 0;
      const std::size_t first_mutant = pop.size() - static_cast<std::size_t>(n_mutation);
      for (int k = 0; k < n_mutation; ++k) {
        if (pop[first_mutant + static_cast<std::size_t>(k)].cost < mutant_parent_cost[static_cast<std::size_t>(k)]) ++better;
      }
      const double factor = 5 * better > n_mutation ? 1.0 / p.success_rule_factor
                            : 5 * better < n_mutation ? p.success_rule_factor : 1.0;
      for (double& s : sigma_gene) s = std::clamp(s * factor, sigma_floor, sigma);
    }
    std::stable_sort(pop.begin(), pop.end(), by_cost);
    worst = std::max(worst, pop.back().cost);
    pop.resize(static_cast<std::size_t>(n_pop));
    result.iterations = it;
    go_on = report(it);
  }
  result.best = pop.front().genes;
  result.best_cost = pop.front().cost;
  return result;
}

}  // namespace hexa
