"""studies/criterion.py: the ranking power (AUC) and the rules of the source's form
against the tug's verdict, on samples whose answers are known by construction."""
from __future__ import annotations

import math
from types import SimpleNamespace as NS

from tethernet_ros.studies.criterion import (SOURCE_RULE, Rule, auc, fit_rule, score,
                                             separation, within_cells_table)


def sample(seed, cqi, pairs, held, success=None):
    ok = cqi <= 2.0 and pairs >= 10 if success is None else success
    return NS(seed=seed, settled_cqi=cqi, locked_pairs=pairs, success=ok,
              tug={"held": held})


def test_auc_counts_pairs_and_ties():
    assert auc([3.0, 4.0], [1.0, 2.0]) == 1.0
    assert auc([1.0, 2.0], [3.0, 4.0]) == 0.0
    assert auc([1.0], [1.0]) == 0.5
    assert auc([2.0, 0.0], [1.0]) == 0.5
    assert math.isnan(auc([], [1.0]))


def test_score_of_the_source_rule():
    s = [sample(0, 0.5, 12, True), sample(1, 0.5, 12, False), sample(2, 3.0, 12, False),
         sample(3, 1.0, 8, True), sample(4, 0.7, 11, True, success=True)]
    sc = score(SOURCE_RULE, s)
    assert (sc.n, sc.held, sc.called) == (5, 3, 3)
    assert (sc.false_captures, sc.missed_captures) == (1, 1)
    assert sc.tpr == 2 / 3 and sc.tnr == 1 / 2 and sc.balanced_accuracy == 0.5 * (2 / 3 + 1 / 2)
    assert sc.precision == 2 / 3 and sc.precision_lo < 2 / 3 < sc.precision_hi


def test_fit_finds_the_separating_thresholds_and_the_check_set_is_apart():
    """Held exactly when CQI <= 0.8 and pairs >= 12: the fit finds a rule that separates
    the selection set perfectly, the source's rule does not, and the check set scores
    the fitted rule on samples it never saw."""
    samples = []
    for i in range(200):
        cqi = 0.05 + 1.9 * ((i * 37) % 200) / 200
        pairs = 9 + (i * 7) % 8
        samples.append(sample(i, cqi, pairs, cqi <= 0.8 and pairs >= 12))
    sel = [s for s in samples if s.seed % 2 == 0]
    rule = fit_rule(sel)
    assert score(rule, sel).balanced_accuracy == 1.0
    assert rule.min_pairs == 12 and 0.75 <= rule.max_cqi <= 0.8
    assert score(SOURCE_RULE, sel).balanced_accuracy < 0.8
    sep = separation("t", samples, lambda s: s.seed % 2 == 0)
    assert sep.fitted == rule and sep.n == 200
    assert sep.fitted_check.n == 100 and sep.fitted_check.balanced_accuracy > 0.95
    assert sep.auc_cqi > 0.5 and sep.auc_pairs > 0.5
    assert "| t: a |" in within_cells_table({"t: a": samples})


def test_untested_samples_are_left_out():
    s = [sample(0, 0.5, 12, True), NS(seed=1, settled_cqi=0.5, locked_pairs=12, success=True,
                                       tug=None),
         NS(seed=2, settled_cqi=math.nan, locked_pairs=0, success=False, tug={"held": False})]
    assert score(Rule(2.0, 10), s).n == 1
