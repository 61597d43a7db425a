#!/usr/bin/env python3
"""The scene format's schema (assets/scenes/scene.schema.json) and mpm_run's own reading agree:
every scene in assets/scenes/ passes both; every malformed case in tests/scene_files/bad/ is
refused by both, the loader with the message in its sibling .expected file; and the schema's
settings are exactly the fields of mpm::forEachField (mpm/include/mpm/settings_fields.h).

    check_scene_files.py SOURCE_DIR MPM_RUN
"""
import glob
import json
import os
import re
import subprocess
import sys

import jsonschema

source, mpm_run = sys.argv[1], sys.argv[2]
failures = []


def check(ok, message):
    if not ok:
        failures.append(message)
        print("FAIL: " + message)


schema = json.load(open(os.path.join(source, "assets/scenes/scene.schema.json")))
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)


def run_check(path):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([mpm_run, "--check", path], capture_output=True, text=True, env=env, timeout=120)


scenes = [p for p in sorted(glob.glob(os.path.join(source, "assets/scenes/*.json"))) if not p.endswith("schema.json")]
check(len(scenes) >= 3, "assets/scenes holds the coupling, cutting and suturing scenes")
for path in scenes:
    errors = [e.message for e in validator.iter_errors(json.load(open(path)))]
    check(not errors, "%s: the schema refuses it: %s" % (path, errors[:3]))
    r = run_check(path)
    check(r.returncode == 0, "%s: mpm_run --check refuses it: %s" % (path, r.stderr.strip()))
    print("ok  %s" % os.path.basename(path))

bad = sorted(glob.glob(os.path.join(source, "tests/scene_files/bad/*.json")))
check(len(bad) >= 10, "tests/scene_files/bad holds the malformed cases")
for path in bad:
    expected = open(path[: -len(".json")] + ".expected").read().strip()
    check(bool(expected), "%s: its .expected file is empty" % path)
    check(not validator.is_valid(json.load(open(path))), "%s: the schema accepts it" % path)
    r = run_check(path)
    check(r.returncode == 1, "%s: mpm_run --check exited with %d, not 1" % (path, r.returncode))
    check(expected in r.stderr, "%s: mpm_run said %r, expected %r" % (path, r.stderr.strip(), expected))
    print("bad %s: %s" % (os.path.basename(path), r.stderr.strip()))


def leaves(node, prefix=""):
    """Key paths of a schema object's properties, down to the values that are not objects."""
    out = set()
    for key, sub in node.get("properties", {}).items():
        if sub.get("type") == "object" and "properties" in sub:
            out |= leaves(sub, prefix + key + ".")
        else:
            out.add(prefix + key)
    return out


fields = open(os.path.join(source, "mpm/include/mpm/settings_fields.h")).read()
listed = {re.sub(r"\[\d+\]$", "", f) for f in re.findall(r'v\("SceneSettings\.([^"]+)"', fields)}
documented = leaves(schema["$defs"]["settings"])
check(listed == documented, "schema settings differ from forEachField: only in the header %s, only in the schema %s"
      % (sorted(listed - documented), sorted(documented - listed)))

print("%d scenes, %d malformed cases, %d settings fields: %s" % (len(scenes), len(bad), len(listed),
      "FAILED" if failures else "schema and loader agree"))
sys.exit(1 if failures else 0)
