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


def test_the_python_example_runs_and_uses_only_the_public_api(tmp_path, monkeypatch):
    """The README's Python example runs as written (one trial on one worker here, for
    time) and reaches only names of ``truthbench.__all__``."""
    import re

    import truthbench

    block = README.split("```python\nimport truthbench as tb\n", 1)[1].split("```", 1)[0]
    used = set(re.findall(r"\btb\.(\w+)", block))
    assert used <= set(truthbench.__all__), used - set(truthbench.__all__)
    assert "from truthbench." not in block
    monkeypatch.chdir(tmp_path)
    (tmp_path / "campaigns").mkdir()
    (tmp_path / "campaigns" / "quickstart.toml").write_text(
        (ROOT / "campaigns" / "quickstart.toml").read_text()
        .replace("record_s = 64.0", "record_s = 8.0"))
    code = "import truthbench as tb\n" + block.replace("trials=4, n_jobs=2", "trials=1, n_jobs=1")
    namespace = {}
    exec(compile(code, "README example", "exec"), namespace)
    assert namespace["H"].shape == (3, 1, 1)
    assert len(namespace["frfs"]) == 2
