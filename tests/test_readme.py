"""The README keeps its promises: the two set-up commands, .ci/run, the effects table."""

from pathlib import Path

from truthbench.effects import EFFECTS

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_readme_opens_with_two_setup_commands_and_ci_runs_the_test_one():
    block = README.split("```bash\n", 1)[1].split("```", 1)[0].strip().splitlines()
    assert len(block) == 2
    assert "truthbench run campaigns/quickstart.toml" in block[0]
    assert block[1] in (ROOT / ".ci" / "run").read_text()


def test_every_effect_and_parameter_is_documented():
    for name, cls in EFFECTS.items():
        assert f"| `{name}` |" in README, name
        assert f'name = "{name}"' in README, f"no snippet for {name}"
        for p in cls.params:
            assert f"`{p.name}`" in README, (name, p.name)
