// Real-coded genetic algorithm with the settings of the paper's Table 7 (Sec. 3.1):
// nVar variables in [VarMin, VarMax] (genes in [0, 1], mapped by the caller to each
// parameter's range), MaxIt iterations, nPop individuals, crossover percentage pc, mutation
// percentage pm, mutation rate mu. Table 7's names are those of the widely used MATLAB
// real-coded GA template (Yarpiz); its operators are implemented as that template defines
// them, which the paper does not spell out (docs/identification.md, "The two fits"):
//   - nc = 2 round(pc nPop / 2) offspring per iteration from parent pairs chosen by
//     roulette wheel with probabilities exp(-beta cost / worst cost), beta = 8;
//   - arithmetic crossover y1 = a x1 + (1 - a) x2, y2 = a x2 + (1 - a) x1 with a drawn per
//     gene uniformly in [-gamma, 1 + gamma], gamma = 0.4, clamped to [VarMin, VarMax];
//   - nm = round(pm nPop) mutants of random members: ceil(mu nVar) genes get Gaussian noise
//     of sigma = 0.1 (VarMax - VarMin), clamped;
//   - parents, offspring and mutants are merged, sorted by cost, truncated to nPop (elitist).
//
// Deterministic for a seed: every random number is drawn on the calling thread in a fixed
// order (own uniform / Box-Muller on std::mt19937_64, not the library distributions); the
// costs of one iteration's offspring are computed by a caller-supplied batch function that
// may spread them over threads (the cost of a genome must not depend on the order).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace hexa {

struct GaParams {
  int num_variables = 7;            // nVar
  double var_min = 0.0;             // VarMin
  double var_max = 1.0;             // VarMax
  int max_iterations = 1000;        // MaxIt
  int population = 100;             // nPop
  double crossover_fraction = 0.8;  // pc
  double mutation_fraction = 0.3;   // pm
  double mutation_rate = 0.02;      // mu
  // Template operators (not in Table 7):
  double crossover_gamma = 0.4;
  double mutation_sigma_fraction = 0.1;
  double selection_pressure = 8.0;  // beta
  // Departures from the template, all off by default here (= the template exactly);
  // hexa_identify chooses (docs/measurements/identification.md, "Why the template GA stalls,
  // and the gene map that fixes it"):
  //   - crossover_per_pair: one a per parent pair (y on the line through x1 and x2,
  //     extended by gamma either side) instead of one a per gene: offspring of two parents
  //     in a narrow diagonal valley stay in it instead of filling the box around them;
  //   - mutation_step: the Gaussian step sigma of a mutated gene:
  //       kRange (template): mutation_sigma_fraction x (VarMax - VarMin), fixed;
  //       kPopulationSpread: per gene mutation_sigma_fraction x (its spread, max - min,
  //         over the population);
  //       kSuccessRule: Rechenberg's 1/5 success rule: starts at the template's sigma, x 1/c
  //         after an iteration in which more than a fifth of the mutants beat the member
  //         they were made from, x c after one with fewer (c = success_rule_factor);
  //     the adapted steps stay within [mutation_sigma_floor, mutation_sigma_fraction] x
  //     (VarMax - VarMin).
  enum class MutationStep { kRange, kPopulationSpread, kSuccessRule };
  bool crossover_per_pair = false;
  MutationStep mutation_step = MutationStep::kRange;
  double mutation_sigma_floor = 1e-9;
  double success_rule_factor = 0.85;
  std::uint64_t seed = 1;
  // Throws std::invalid_argument naming the field, value and limit.
  void Validate() const;
};

using Genome = std::vector<double>;
// Costs (>= 0, finite; a non-finite cost is treated as the worst) of a batch of genomes.
using GaBatchCost = std::function<void(const std::vector<Genome>& genomes, std::vector<double>& costs)>;

struct GaProgress {
  int iteration = 0;             // 0 = the initial population
  double best_cost = 0.0;
  double mean_cost = 0.0;        // of the population
  // Diagnostics: the largest gene spread (max - min over the population, over the genes)
  // and the ratio of the roulette wheel's largest to smallest selection probability.
  double max_gene_spread = 0.0;
  double selection_ratio = 1.0;
  std::uint64_t evaluations = 0;
};
// Return false to stop after this iteration.
using GaProgressFn = std::function<bool(const GaProgress&)>;

struct GaResult {
  Genome best;
  double best_cost = 0.0;
  int iterations = 0;            // completed
  std::uint64_t evaluations = 0;
  std::vector<double> best_cost_history;  // per iteration, [0] = initial population
};

GaResult RunGeneticAlgorithm(const GaParams& params, const GaBatchCost& cost,
                             const GaProgressFn& progress = {});

}  // namespace hexa
