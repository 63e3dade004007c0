// Multi-hypothesis joint view selection (paper section 3.2, eqs. 8-14), and
// the heuristic top-K aggregation used by the "\MHJ" ablation.
//
// Input is the cost matrix M of eq. 8: one row per propagated hypothesis (at
// most 8; rows of hypotheses that could not be formed are left out), one
// column per source view. Output is a weight per view (psi_mod of eq. 12) with
// which any hypothesis of this pixel is then scored by eq. 14.
//
// Our reading of eqs. 12-13 (the printed equations are ambiguous):
//  - S_t: views with more than n1 costs below tau_mc(t) (eq. 9) and fewer
//    than n2 costs above tau_up.
//  - psi(j) (eq. 11): mean confidence C(m_ij) = exp(-m_ij^2 / (2 beta^2))
//    over the hypotheses.
//  - A view of S_t that was the most important view v_{t-1} of the last
//    iteration has its importance multiplied by 2 (eq. 13); the k most
//    important views of S_t keep their importance as weight, the others of
//    S_t weigh 0 (section 3.2: "we only remain at most k important views").
//  - A view not in S_t that was selected (weighted) in the last iteration
//    weighs 0.2 (eq. 12, second case).
//  - v_t is the view of S_t with the highest psi (eq. 11, unmodified).
//  - If no view gets a weight (a pixel with no good view yet, e.g. in the
//    first iteration), the pixel falls back to the heuristic aggregation so
//    that it can still improve; no NaN and no division by zero arise.
#pragma once

#include "amhmvs_mapping/mvs/hd.h"
#include "amhmvs_mapping/mvs/matching_cost.h"

namespace amhmvs {
namespace mvs {

constexpr int kNoView = -1;

struct SelectionParams {
  float tau_mc_init, tau_alpha, tau_up, beta;
  int n1, n2, top_k;
  float best_view_boost, previous_selection_weight;
  int heuristic_k;
};

// Result of view selection at one pixel.
struct ViewWeights {
  float weight[32];    // psi_mod per view; all zero => heuristic aggregation
  uint32_t selected;   // views with non-zero weight from S_t (kept for t+1)
  int best_view;       // v_t, or kNoView
  bool heuristic;      // true when the fallback aggregation is in use
};

// Eq. 9.
AMHMVS_HD float goodCostThreshold(const SelectionParams& p, int iteration) {
  const float t = static_cast<float>(iteration);
  return p.tau_mc_init * expf(-t * t / p.tau_alpha);
}

// Eq. 10.
AMHMVS_HD float confidence(const SelectionParams& p, float cost) {
  return expf(-cost * cost / (2.0f * p.beta * p.beta));
}

// costs: row-major, `rows` x `num_views`, with row stride `stride`.
AMHMVS_HD void jointViewSelection(const SelectionParams& p, const float* costs, int rows,
                                  int stride, int num_views, int iteration,
                                  uint32_t previous_selected, int previous_best,
                                  ViewWeights* out) {
  const float tau_mc = goodCostThreshold(p, iteration);
  float importance[32];
  uint32_t good = 0;
  out->best_view = kNoView;
  float best_importance = -1.0f;
  for (int j = 0; j < num_views; ++j) {
    int below = 0, above = 0;
    float confidence_sum = 0.0f;
    for (int i = 0; i < rows; ++i) {
      const float m = costs[i * stride + j];
      below += m < tau_mc;
      above += m > p.tau_up;
      confidence_sum += confidence(p, m);
    }
    importance[j] = rows > 0 ? confidence_sum / rows : 0.0f;  // eq. 11
    if (below > p.n1 && above < p.n2) {
      good |= 1u << j;
      if (importance[j] > best_importance) {
        best_importance = importance[j];
        out->best_view = j;
      }
      if (j == previous_best) importance[j] *= p.best_view_boost;  // eq. 13
    }
  }
  // Keep the top_k most important good views (ties: lower view index).
  uint32_t kept = 0;
  for (int slot = 0; slot < p.top_k; ++slot) {
    int pick = kNoView;
    for (int j = 0; j < num_views; ++j) {
      if (((good & ~kept) >> j) & 1u) {
        if (pick == kNoView || importance[j] > importance[pick]) pick = j;
      }
    }
    if (pick == kNoView) break;
    kept |= 1u << pick;
  }
  float total = 0.0f;
  for (int j = 0; j < num_views; ++j) {
    float w = 0.0f;
    if ((kept >> j) & 1u) {
      w = importance[j];
    } else if (!((good >> j) & 1u) && ((previous_selected >> j) & 1u)) {
      w = p.previous_selection_weight;  // eq. 12, second case
    }
    out->weight[j] = w;
    total += w;
  }
  out->selected = kept;
  out->heuristic = !(total > 0.0f);
}

// Eq. 14 for one hypothesis, or the heuristic mean of its heuristic_k best
// costs when `weights.heuristic`. `costs` holds the hypothesis's cost per
// view; views with zero weight are not read in the weighted case.
AMHMVS_HD float aggregateCost(const SelectionParams& p, const ViewWeights& weights,
                              const float* costs, int num_views) {
  if (!weights.heuristic) {
    float weighted = 0.0f, total = 0.0f;
    for (int j = 0; j < num_views; ++j) {
      if (weights.weight[j] > 0.0f) {
        weighted += weights.weight[j] * costs[j];
        total += weights.weight[j];
      }
    }
    return weighted / total;
  }
  // Mean of the k smallest costs: repeated selection of the minimum (k is small).
  const int k = p.heuristic_k < num_views ? p.heuristic_k : num_views;
  uint32_t used = 0;
  float sum = 0.0f;
  for (int n = 0; n < k; ++n) {
    int pick = kNoView;
    for (int j = 0; j < num_views; ++j) {
      if (!((used >> j) & 1u) && (pick == kNoView || costs[j] < costs[pick])) pick = j;
    }
    used |= 1u << pick;
    sum += costs[pick];
  }
  return k > 0 ? sum / k : kMaxCost;
}

AMHMVS_HD bool needsView(const ViewWeights& weights, int view) {
  return weights.heuristic || weights.weight[view] > 0.0f;
}

}  // namespace mvs
}  // namespace amhmvs
