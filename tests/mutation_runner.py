"""mutation_runner.py — the loop of the mutation scripts (mutate_material.py, mutate_textures.py).

run_mutations applies one mutation at a time (a source file, a pattern that must occur once in
it, its replacement), rebuilds `targets`, runs the named test program with a JUnit report and
lists the test cases that fail; the source is restored after each mutation and at the end,
whatever happens. Every mutation must make at least one test case fail: it returns the exit
code, 1 if one survived (or failed to build). MUTATE_ONLY=<text> keeps only the mutations whose
name contains <text>.
"""
import os
import re
import subprocess


def _run(cmd):
    return subprocess.run(cmd, shell=True, capture_output=True, text=True)


def run_mutations(mutations, build, targets_of, restore_targets, env=""):
    """mutations: (path, test, name, original, mutated); targets_of(test): what to rebuild."""
    only = os.environ.get("MUTATE_ONLY", "")
    mutations = [m for m in mutations if only in m[2]]
    survivors = 0
    originals = {}
    try:
        for path, test, name, a, b in mutations:
            if path not in originals:
                originals[path] = open(path).read()
            src = originals[path]
            assert src.count(a) == 1, f"{name}: pattern not found once in {path}"
            open(path, "w").write(src.replace(a, b))
            r = _run(f"nice cmake --build {build} -j2 --target {targets_of(test)}")
            if r.returncode:
                print(f"[{path}] {name}: BUILD FAILED\n{r.stdout[-800:]}")
                survivors += 1
            else:
                r = _run(f"{env} {build}/tests/{test} -r junit")
                failing = sorted(set(re.findall(
                    r'<testcase classname="[^"]*" name="([^"]*)"[^>]*>\s*<failure', r.stdout)))
                print(f"[{path}] {name}: {'caught' if failing else 'SURVIVED'}", flush=True)
                for f in failing:
                    print(f"    fails: {f}")
                survivors += 0 if failing else 1
            open(path, "w").write(src)
    finally:
        for path, src in originals.items():
            open(path, "w").write(src)
        _run(f"nice cmake --build {build} -j2 --target {restore_targets}")
    print(f"{len(mutations) - survivors} of {len(mutations)} mutations caught")
    return 1 if survivors else 0
