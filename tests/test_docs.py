"""Every hook has a heading in docs/hooks.md with its signature, and a test that uses it."""

from __future__ import annotations

import inspect

from conftest import REPO
from postproc import hookspecs


def _hooks():
    return [name for name, value in vars(hookspecs).items() if name.startswith("postproc_") and inspect.isfunction(value)]


def test_every_hook_is_documented_with_its_signature():
    text = (REPO / "docs" / "hooks.md").read_text()
    for name in _hooks():
        returns = inspect.signature(getattr(hookspecs, name)).return_annotation.strip("'\"")
        assert f"## `{name}() -> {returns}`" in text, name


def test_every_hook_has_a_test():
    tests = "".join(path.read_text() for path in (REPO / "tests").glob("test_*.py") if path.name != "test_docs.py")
    for name in _hooks():
        assert name in tests, f"no test uses {name}"


def test_the_reader_example_in_hooks_md_reads_its_export(tmp_path, run):
    """The documented vendor reader, registered as a plugin, reads a 220 deg export in every command."""
    import importlib.util
    import re

    from postproc import plugins as registry
    from postproc.simulator import ballbar_test, generator, load

    text = (REPO / "docs" / "hooks.md").read_text()
    section = text.split("## Example: a reader for a ballbar export", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    module_path = tmp_path / "vendor_reader.py"
    module_path.write_text(code)
    spec = importlib.util.spec_from_file_location("vendor_reader", module_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    simulation, _ = load(str(REPO / "samples" / "machines" / "v40r-sim.toml"))
    exports = []
    for direction, start in (("ccw", 200.0), ("cw", -20.0)):
        test = ballbar_test(simulation, generator(3, direction), direction, start=start, capture=220.0, overtravel=2.0)
        rows = "".join(f"{a:.2f}  {d * 1000:.4f}\n" for a, d in zip(test.angles, test.deviations))
        export = tmp_path / f"{direction}.bbx"
        export.write_text(f"BALLBAR EXPORT v2\nRadius: 100.000 mm\nDirection: {direction.upper()}\n"
                          f"Feed: 1000 mm/min\nAngle[deg]  Error[um]\n{rows}")
        exports.append(str(export))
    manager = registry.manager()
    manager.register(module, name="vendor-reader-example")
    try:
        result = run("ballbar", *exports, "--json")
        assert result.exit_code == 0, result.stderr
        import json

        report = json.loads(result.stdout)
        assert abs(report["captured_arc_deg"]["cw"]["span"] - 220.0) < 0.6
        assert abs(report["scaling_x"] - 30e-6) < 4e-6 and abs(report["backlash_z_mm"] - 0.003) < 0.0006
        fitted = run("fit", "--plugin", "parametric", *(a for e in exports for a in ("--ballbar", e)),
                     "-o", str(tmp_path / "model.json"))
        assert fitted.exit_code == 0, fitted.stderr
        broken = tmp_path / "broken.bbx"
        broken.write_text(open(exports[0]).read().replace("\n12.00  ", "\n12.00 x "))
        refused = run("ballbar", str(broken))
        assert refused.exit_code == 3 and refused.stderr.startswith(f"{broken}:")
        assert "expected an angle and an error in um" in refused.stderr
    finally:
        manager.unregister(module)
