"""Every numeric move keyword of the core's list (`multistep.MOVE_PARAMS`) is taken by
`plan` and `simulate`, in the stub as at run time, with the command line's meaning."""

import ast
import json
import pathlib

import pytest

import multistep

STUB = pathlib.Path(__file__).resolve().parents[1] / "multistep.pyi"


def stub_keywords(func):
    for node in ast.parse(STUB.read_text()).body:
        if isinstance(node, ast.FunctionDef) and node.name == func:
            return {a.arg for a in node.args.args + node.args.kwonlyargs}
    raise AssertionError(f"{func} is not in the stub")


def test_the_list_is_the_core_list():
    assert len(multistep.MOVE_PARAMS) == len(set(multistep.MOVE_PARAMS)) == 12
    assert {"vmax", "amax", "jmax", "smax", "accel_time", "rho"} <= set(multistep.MOVE_PARAMS)


@pytest.mark.parametrize("name", multistep.MOVE_PARAMS)
def test_every_move_value_is_a_keyword_as_on_the_command_line(cli, name):
    assert name in stub_keywords("plan") and name in stub_keywords("simulate")
    kw = {"steps": 200, name: 0.5}
    r = cli("plan", "--steps", "200", f"--{name.replace('_', '-')}", "0.5", "--format", "json",
            check=False)
    if r.returncode != 0:
        with pytest.raises(multistep.PlanError) as e:
            multistep.plan(**kw)
        assert r.stderr.strip() == f"error: {e.value}"
    else:
        assert multistep.plan(**kw).summary == json.loads(r.stdout)
    # simulate reads the same keyword (a TypeError would name it as unexpected)
    try:
        multistep.simulate(motor="42mm", **kw)
    except multistep.MultistepError:
        pass
