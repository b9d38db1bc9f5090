"""Sweeps: learners x settings x seeds from a spec file, each trial a Ray Tune trial that keeps its state in
its own folder (`pendkit sweep SPEC --out DIR`, `pendkit sweep report DIR`; docs/sweeps.md).

| module        | what                                                              |
|---------------|-------------------------------------------------------------------|
| spec.py       | the spec file (YAML/TOML) and the trials it expands to             |
| trial.py      | one trial: learn, check, checkpoint, resume, result.json           |
| ray_runner.py | the trials on Ray Tune, locally or on a cluster                    |
| report.py     | the tidy table, the summary lines, the figure, lab 08's sweep file |
"""
