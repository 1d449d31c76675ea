"""Paper Figure 4, Tables 2 and 3 on Driving as shipped: the paper's worlds (weight_ranges = "safe") and
non-pessimal PIOB baseline (10 seeded worlds, every state once)."""

from tests.paper import paper_world_tests

(
    passive,
    active,
    test_paper_world_figure_4_nevd_rule_is_accurate_and_efficient,
    test_paper_world_table_2_piob_rule_as_the_papers_code_scores_it,
    test_paper_world_table_3_active_nevd_needs_fewer_states_at_equal_f1,
) = paper_world_tests("driving")
