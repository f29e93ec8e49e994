"""The stopping rules (passes, time, target error) and their refusals, in the library's
terms."""

import pytest

from blockhash.errors import InputError
from blockhash.passes.plan import RenderPlan, TargetOutOfReach
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes


@pytest.mark.gl
def test_plan_rules(plane):
    r = Renderer(plane)
    assert run_passes(r, RenderPlan(passes=2)) == "2 passes" and r.passes == 2
    r = Renderer(plane)
    assert run_passes(r, RenderPlan(passes=None, seconds=1e-9)).startswith("time limit")
    assert r.passes == 1
    r = Renderer(plane)
    why = run_passes(r, RenderPlan(passes=50, target_error=0.5))
    assert why.startswith("estimated error") and r.film.estimated_error() <= 0.5
    assert r.passes < 50
    with pytest.raises(TargetOutOfReach, match="target_error=1e-06 cannot be reached within "
                                               "passes=5"):
        run_passes(Renderer(plane), RenderPlan(passes=5, target_error=1e-6))


@pytest.mark.parametrize("kwargs, match", [
    ({"passes": 0}, "passes=0: a render runs at least one pass"),
    ({"passes": None, "seconds": 0}, "seconds=0: the time limit must be a positive"),
    ({"passes": None, "seconds": -1.0}, "seconds=-1.0: "),
    ({"target_error": 0}, "target_error=0: .* must be > 0"),
    ({"target_error": 0.1, "passes": 1}, "cannot be reached within passes=1"),
    ({"passes": None}, "no pass limit needs seconds= or target_error="),
])
def test_bad_stopping_rules_name_the_setting_and_the_way_out(kwargs, match):
    """In the library's terms (its keywords), never the command line's flags."""
    with pytest.raises(InputError, match=match) as caught:
        RenderPlan(**kwargs)
    assert "--" not in str(caught.value)

