// The tables `dtflop predict` and `dtflop run` print: a computation's cost counts and the
// model's prediction, component by component.
#pragma once

#include "model/cost_counts.hpp"
#include "model/predict.hpp"

namespace dtflop::cli {

void print_counts(const CostCounts& counts);
void print_prediction(const Prediction& prediction);

}  // namespace dtflop::cli
