"""Seeded fuzzing of the three bundled examples through ``asmplan validate`` (and ``run``).

Each mutant is one random edit of an example, of the kinds a hand-edited or generated file
gets wrong: a number replaced by a hostile one (huge, negative, zero, non-finite, 4,400
digits, a wrongly tagged scalar), any value replaced by one of another type (a list, a
mapping, null, an alias), a line deleted, duplicated or re-indented, a value
replaced by another line's, a control character, a truncated file, an alias bomb or a
recursive alias appended. For every mutant:

* the exit code is 0, 1 or 2, never 3 (an internal error) and no traceback;
* with exit code 2, every reported issue is located (``file:line:col:``);
* one ``validate`` takes at most 2 s of CPU and 200 MB of memory allocated (tracemalloc's
  peak, numpy included).

A few of the mutants that validate are also run (``run --fidelity fast --no-report``): exit
0 or 1, and no NaN or Infinity in any file written.

Bounded for CI: ``ASMPLAN_FUZZ_MUTANTS`` mutants (default 240, 80 per example) from seed
``ASMPLAN_FUZZ_SEED`` (default 14), and ``ASMPLAN_FUZZ_RUNS`` accepted mutants run (default
3). A longer campaign: ``ASMPLAN_FUZZ_MUTANTS=3000 ASMPLAN_FUZZ_SEED=7 pytest tests/test_fuzz.py``.
"""

from __future__ import annotations

import os
import re
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from asmplan.cli import main
from tests.conftest import EXAMPLE_NAMES, example_path

N_MUTANTS = int(os.environ.get("ASMPLAN_FUZZ_MUTANTS", "240"))
SEED = int(os.environ.get("ASMPLAN_FUZZ_SEED", "14"))
N_RUNS = int(os.environ.get("ASMPLAN_FUZZ_RUNS", "3"))
MAX_CPU_S = 2.0
MAX_MEMORY_B = 200 * 2**20

HOSTILE_NUMBERS = (
    "0", "-1", "-0.0", "1.0e+308", "-1.0e+308", "1e30", "1.0e+400", ".nan", ".inf", "-.inf", "1e-30",
    "9" * 4400, "1" + "0" * 309, "99999999999999999999", "0x7fffffff", "0o777", "1:30:00", "1_000_000",
    "!!float abc", '!!int ""', "!!bool maybe", "!!str 12", "!!binary aGk=", "!!timestamp 2001-12-14",
    '"\\ud800"', "~", "[]", "{}", "[1, 2]", "true", "abc", "1e", "0.000001", "100000", "3.14159",
)
NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?![\w.])")
VALUE = re.compile(r"(?<=: )[^\s\[\]{},#][^,\]}\n#]*")  # a scalar after "key: "
HOSTILE_VALUES = ("[x]", "{a: 1}", "~", '""', "[]", "{}", "[[1]]", "*nope", "&a [*a]", "true", "- x")


def _mutate(text: str, rng: np.random.Generator) -> str:
    lines = text.split("\n")
    kind = int(rng.integers(0, 13))
    numbers = list(NUMBER.finditer(text))
    if kind <= 3 and numbers:  # a number replaced by a hostile one (most common)
        m = numbers[int(rng.integers(len(numbers)))]
        new = HOSTILE_NUMBERS[int(rng.integers(len(HOSTILE_NUMBERS)))]
        return text[: m.start()] + new + text[m.end():]
    if kind >= 11:  # any value replaced by one of another type (a list, a mapping, null...)
        values = list(VALUE.finditer(text))
        m = values[int(rng.integers(len(values)))]
        new = HOSTILE_VALUES[int(rng.integers(len(HOSTILE_VALUES)))]
        return text[: m.start()] + new + text[m.end():]
    i = int(rng.integers(len(lines)))
    if kind == 4:
        del lines[i]
    elif kind == 5:
        lines.insert(i, lines[i])
    elif kind == 6:
        lines[i] = " " * int(rng.integers(0, 5)) + lines[i].lstrip()
    elif kind == 7:  # one line's value on another line's key
        j = int(rng.integers(len(lines)))
        if ":" in lines[i] and ":" in lines[j]:
            lines[i] = lines[i].split(":", 1)[0] + ":" + lines[j].split(":", 1)[1]
    elif kind == 8:
        pos = int(rng.integers(len(text)))
        return text[:pos] + chr(int(rng.choice([0, 7, 8, 27, 127, 0xFFFE]))) + text[pos:]
    elif kind == 9:
        return text[: int(rng.integers(len(text)))]
    else:
        extra = ["loop: &L [1, *L]",
                 "bomb0: &b0 [x, x, x, x, x, x, x, x, x]\n" + "\n".join(
                     f"bomb{k}: &b{k} [" + ", ".join([f"*b{k - 1}"] * 9) + "]" for k in range(1, 9)),
                 "deep: " + "[" * 800 + "]" * 800,
                 "product: *undefined"]
        return text + "\n" + extra[int(rng.integers(len(extra)))] + "\n"
    return "\n".join(lines)


def _mutants() -> list[tuple[str, str]]:
    rng = np.random.default_rng(SEED)
    texts = {name: example_path(name).read_text(encoding="utf-8") for name in EXAMPLE_NAMES}
    out = []
    for k in range(N_MUTANTS):
        name = EXAMPLE_NAMES[k % len(EXAMPLE_NAMES)]
        out.append((f"{name}-{k}", _mutate(texts[name], rng)))
    return out


def _validate(path: Path, capsys) -> tuple[int, str, float, int]:
    tracemalloc.start()
    t0 = time.process_time()
    code = main(["validate", str(path)])
    cpu = time.process_time() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return code, capsys.readouterr().err, cpu, peak


def test_fuzzed_examples_give_located_errors_within_budget(tmp_path, capsys) -> None:
    accepted: list[tuple[str, Path]] = []
    codes: dict[int, int] = {}
    for name, text in _mutants():
        path = tmp_path / f"{name}.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        code, err, cpu, peak = _validate(path, capsys)
        codes[code] = codes.get(code, 0) + 1
        assert code in (0, 1, 2), f"{name}: exit {code}\n{err}"
        assert "Traceback" not in err and "internal error" not in err, f"{name}\n{err}"
        assert cpu <= MAX_CPU_S, f"{name}: validate took {cpu:.2f} s of CPU"
        assert peak <= MAX_MEMORY_B, f"{name}: validate allocated {peak / 2**20:.0f} MB"
        if code == 2:
            issues = err.strip().splitlines()[:-1]
            assert issues, f"{name}: exit 2 with no issue\n{err}"
            located = re.compile(re.escape(str(path)) + r":\d+:\d+: ")
            assert all(located.match(line) for line in issues), f"{name}: an unlocated issue\n{err}"
        elif code == 0 and text not in {example_path(n).read_text(encoding="utf-8") for n in EXAMPLE_NAMES}:
            accepted.append((name, path))
    # the campaign exercises both outcomes (a mutation operator that never bites is a bug)
    assert codes.get(2, 0) > N_MUTANTS // 3 and codes.get(0, 0) > 0, codes
    _run_accepted(accepted, tmp_path, capsys)


def _run_accepted(accepted: list[tuple[str, Path]], tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(SEED)
    for k in rng.permutation(len(accepted))[:N_RUNS]:
        name, path = accepted[int(k)]
        out = tmp_path / f"out-{name}"
        code = main(["run", str(path), "-o", str(out), "--fidelity", "fast", "--no-report", "-j", "1"])
        captured = capsys.readouterr()
        assert code in (0, 1), f"{name}: run exit {code}\n{captured.err}"
        if code == 1:  # a failure (or a step the preset does not resolve) says why
            assert ("no plan:" in captured.out or "fail physically" in captured.out
                    or "not resolved at fidelity fast" in captured.out), captured.out
        for f in out.glob("*.json"):
            body = f.read_text(encoding="utf-8")
            assert not re.search(r"\b(NaN|-?Infinity)\b", body), f"{name}: non-finite value in {f.name}"


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_the_examples_themselves_validate(name, capsys) -> None:
    code, err, _cpu, _peak = _validate(example_path(name), capsys)
    assert code == 0, err
