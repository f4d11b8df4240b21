"""Repository rules that no compiler checks (python3 standard library only).

1. docs/BENCHMARKS.md is a reference of the current results and the method: at most 600 lines. Runs,
   rounds and superseded tables go to docs/bench/history/, one file per topic.
2. No file of the repository names a path of the machine it was written on (a home, the scratch
   directory, the shared work tree): those mean nothing in another clone. Use a path relative to the
   repository or a placeholder such as <scratch>/, <data>/, <repo>.

The files checked are git's tracked files when the source tree is a git checkout, else every file
under it except build directories. Usage: repository_rules_test.py SOURCE_DIR
"""
import os
import re
import subprocess
import sys
import unittest

BENCHMARKS_MAX_LINES = 600
# Built from pieces so that this file does not match itself.
MACHINE_PATH = re.compile("(?<![A-Za-z0-9_.~-])/(" + "|".join(["wo" + "rk", "t" + "mp", "ho" + "me", "ro" + "ot"]) + ")/")
SKIPPED_DIRS = {".git", "build", "build-asan", "build-tsan", "__pycache__"}

SOURCE_DIR = os.path.abspath(sys.argv.pop(1) if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))


def repository_files(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], capture_output=True, check=True)
        names = [n for n in out.stdout.decode("utf-8", "surrogateescape").split("\0") if n]
        if names:
            return names
    except (OSError, subprocess.CalledProcessError):
        pass
    names = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = [d for d in dirnames if d not in SKIPPED_DIRS and not d.startswith("build")]
        names += [os.path.relpath(os.path.join(dirpath, f), root) for f in filenames]
    return names


def machine_paths_in(text):
    """(line number, line) of every line that names a machine path."""
    return [(i + 1, line.strip()) for i, line in enumerate(text.splitlines()) if MACHINE_PATH.search(line)]


class RepositoryRules(unittest.TestCase):
    def test_benchmarks_doc_is_a_reference(self):
        with open(os.path.join(SOURCE_DIR, "docs", "BENCHMARKS.md"), encoding="utf-8") as f:
            lines = f.read().count("\n")
        self.assertLessEqual(lines, BENCHMARKS_MAX_LINES,
                             "docs/BENCHMARKS.md has %d lines: move the superseded runs to docs/bench/history/" % lines)

    def test_no_file_names_a_machine_path(self):
        found = []
        names = repository_files(SOURCE_DIR)
        self.assertGreater(len(names), 100, "the repository's files were not found under " + SOURCE_DIR)
        for name in names:
            path = os.path.join(SOURCE_DIR, name)
            if not os.path.isfile(path):
                continue  # deleted in the work tree, or a broken link
            with open(path, "rb") as f:
                data = f.read()
            if b"\0" in data[:8192]:
                continue  # binary: images, recordings, meshes
            found += ["%s:%d: %s" % (name, n, line[:160]) for n, line in machine_paths_in(data.decode("utf-8", "replace"))]
        self.assertEqual(found, [], "machine paths (use a relative path or a placeholder):\n" + "\n".join(found))

    def test_the_pattern_finds_machine_paths_and_nothing_else(self):
        # The rule itself, so that a pattern that matches nothing cannot pass the test above.
        hits = ["--out /" + "tmp/x", "`/" + "work/shared/data`", "/" + "home/u/a.png", "(/" + "root/.cache)"]
        misses = ["/dev/null", "docs/bench/tmp/x", "<scratch>/x", "build/tmp/", "~/" + "tmp/", "http://example.org/" + "home/"]
        for text in hits:
            self.assertEqual(len(machine_paths_in(text)), 1, text)
        for text in misses:
            self.assertEqual(machine_paths_in(text), [], text)


if __name__ == "__main__":
    unittest.main()
