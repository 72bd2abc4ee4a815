"""ctest: every shipped case (cases/*.json), and the effective case `mpmflow case` prints for
each, validates against cases/mpmflow_case.schema.json (python3-jsonschema); a case the parser
rejects is rejected by the schema too for a few typical mistakes; and every default the schema
states is the one the parser takes (the effective case of a case that sets only what it must).
Prints FAIL lines; exits 1 on any.

  validate_cases.py MPMFLOW_BINARY SOURCE_DIR
"""
import glob
import json
import os
import subprocess
import sys

import jsonschema

binary, source_dir = sys.argv[1], sys.argv[2]
schema_path = os.path.join(source_dir, "cases", "mpmflow_case.schema.json")
with open(schema_path) as f:
    schema = json.load(f)
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)
failures = 0


def check(condition, message):
    global failures
    print(("ok   " if condition else "FAIL ") + message)
    failures += 0 if condition else 1


def schema_errors(document):
    """The schema's complaints about `document`, each as "path: message"."""
    return [f"{'/'.join(map(str, e.path))}: {e.message}" for e in validator.iter_errors(document)]


def effective_case(path):
    """The effective case `mpmflow case PATH` prints, or None (after a FAIL line) if it does not exit 0."""
    run = subprocess.run([binary, "case", path], capture_output=True, text=True)
    check(run.returncode == 0, f"mpmflow case {os.path.basename(path)} exits 0")
    return json.loads(run.stdout) if run.returncode == 0 else None


cases = sorted(f for f in glob.glob(os.path.join(source_dir, "cases", "*.json")) if f != schema_path)
check(len(cases) >= 4, f"{len(cases)} shipped cases")
for path in cases:
    with open(path) as f:
        document = json.load(f)
    errors = schema_errors(document)
    check(not errors, f"{os.path.basename(path)} validates" + ("" if not errors else f": {errors}"))
    effective = effective_case(path)
    if effective is not None:
        errors = schema_errors(effective)
        check(not errors, f"its effective case validates" + ("" if not errors else f": {errors}"))

with open(os.path.join(source_dir, "cases", "sod.json")) as f:
    sod = json.load(f)
for what, edit in [("an unknown key", lambda d: d["time"].update(cfll=1)),
                   ("a wrong type", lambda d: d["domain"].update(cells_x=100.5)),
                   ("an out-of-range value", lambda d: d["time"].update(cfl=3)),
                   ("a bad enum", lambda d: d.update(boundaries={"left": {"type": "wall"}}))]:
    document = json.loads(json.dumps(sod))
    edit(document)
    check(not validator.is_valid(document), f"the schema rejects {what}")

# The schema's defaults against the parser's: each key with a default (the minimal case, the test
# programs' too, sets none of them) has that value in the minimal case's effective case.
minimal_effective = effective_case(os.path.join(source_dir, "tests", "data", "minimal_case.json"))
defaults_checked = 0


def check_defaults(node, value, path):
    global defaults_checked
    if "$ref" in node:
        node = schema["$defs"][node["$ref"].rsplit("/", 1)[-1]]
    if "default" in node and not isinstance(value, (dict, list)):
        defaults_checked += 1
        check(value == node["default"], f"{path}: the schema's default {node['default']!r}, the parser's {value!r}")
    if isinstance(value, dict):
        for key, child in node.get("properties", {}).items():
            if key in value:
                check_defaults(child, value[key], path + "/" + key)


if minimal_effective is not None:
    check_defaults(schema, minimal_effective, "")
check(defaults_checked >= 20, f"{defaults_checked} schema defaults checked against the parser's")
sys.exit(1 if failures else 0)
