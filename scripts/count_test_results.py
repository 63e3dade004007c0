#!/usr/bin/env python3
"""Prints "N passed, N failed, N skipped" over test results: gtest XML files,
rostest result folders, "script:EXIT_CODE" of a scripted test, "skipped".
Used by run_tests.sh (the whole suite and --fast)."""
import glob, os, sys, xml.etree.ElementTree as ET

def gtest_counts(path):
    if not os.path.exists(path):  # the test program crashed before writing
        return 0, 1, 0
    root = ET.parse(path).getroot()
    total, failed = int(root.get("tests")), int(root.get("failures")) + int(root.get("errors"))
    skipped = sum(1 for case in root.iter("testcase") if case.find("skipped") is not None)
    return total - failed - skipped, failed, skipped

def rostest_counts(directory):
    # rosunit-*.xml: the test node's cases; rostest-*.xml: the launch as a whole
    # (a crash or time-out of the test node shows only there).
    if directory == "skipped":
        return 0, 0, 1
    passed = failed = 0
    for path in glob.glob(os.path.join(directory, "**", "rosunit-*.xml"), recursive=True):
        for case in ET.parse(path).getroot().iter("testcase"):
            bad = case.find("failure") is not None or case.find("error") is not None
            failed += bad
            passed += not bad
    wrapper_failed = 0
    wrappers = glob.glob(os.path.join(directory, "**", "rostest-*.xml"), recursive=True)
    for path in wrappers:
        root = ET.parse(path).getroot()
        wrapper_failed += int(root.get("failures", 0)) + int(root.get("errors", 0))
    if not wrappers or (wrapper_failed and not failed) or passed + failed == 0:
        failed += max(1, wrapper_failed)
    return passed, failed, 0

def script_counts(entry):  # "script:EXIT_CODE" of a scripted test
    return (1, 0, 0) if entry == "script:0" else (0, 1, 0)

counts = [gtest_counts(a) if a.endswith(".xml") else script_counts(a) if a.startswith("script:")
          else rostest_counts(a) for a in sys.argv[1:]]
passed, failed, skipped = (sum(c[i] for c in counts) for i in range(3))
print(f"{passed} passed, {failed} failed, {skipped} skipped")
