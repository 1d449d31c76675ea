"""Paper Figure 4, Tables 2 and 3 on Driving (10 seeded worlds, every state once), on the
package's original variants (tests.paper.ORIGINAL); test_paper_driving_paper_world.py checks the
shipped ones."""

from tests.paper import paper_tests

(
    passive,
    active,
    test_figure_4_nevd_rule_is_accurate_and_efficient,
    test_table_2_piob_rule,
    test_table_3_active_needs_fewer_states_at_equal_f1,
) = paper_tests("driving")
