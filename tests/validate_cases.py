"""ctest: every shipped case (cases/*.json), and the effective case `mpmflow case` prints for
each, validates against cases/mpmflow_case.schema.json (python3-jsonschema); a case the parser
rejects is rejected by the schema too for a few typical mistakes. Prints FAIL lines; exits 1 on any.

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


cases = sorted(f for f in glob.glob(os.path.join(source_dir, "cases", "*.json")) if f != schema_path)
check(len(cases) >= 4, f"{len(cases)} shipped cases")
for path in cases:
    with open(path) as f:
        document = json.load(f)
    errors = [f"{'/'.join(map(str, e.path))}: {e.message}" for e in validator.iter_errors(document)]
    check(not errors, f"{os.path.basename(path)} validates" + ("" if not errors else f": {errors}"))
    effective = subprocess.run([binary, "case", path], capture_output=True, text=True)
    check(effective.returncode == 0, f"mpmflow case {os.path.basename(path)} exits 0")
    errors = [f"{'/'.join(map(str, e.path))}: {e.message}" for e in validator.iter_errors(json.loads(effective.stdout))]
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
sys.exit(1 if failures else 0)
