import pytest

from mjsuff.bounds.hoeffding import abbeel_ng_demos, syed_schapire_demos
from mjsuff.cli import main

TABLE_1 = {
    0.1: (1_624_056, 3_654_126),
    0.2: (406_014, 913_532),
    0.3: (180_451, 406_014),
    0.4: (101_504, 228_383),
    0.5: (64_963, 146_166),
}


@pytest.mark.parametrize("eps", sorted(TABLE_1))
def test_table_1_exactly(eps):
    assert (abbeel_ng_demos(eps), syed_schapire_demos(eps)) == TABLE_1[eps]


def test_bounds_are_the_smallest_integers_that_hold():
    import math

    m = abbeel_ng_demos(0.3)
    f = lambda m: (1 / 0.05) * math.sqrt(8 / m * math.log(8 / 0.05))  # noqa: E731
    assert f(m) <= 0.3 < f(m - 1)


def test_cli_prints_table_1(capsys):
    assert main(["hoeffding"]) == 0
    out = capsys.readouterr().out
    for a, b in TABLE_1.values():
        assert f"{a:,}" in out and f"{b:,}" in out
