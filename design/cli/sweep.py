"""``gantry sweep``: margins and bandwidth across payloads, Monte Carlo over the spec's uncertainty."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import PlantFromOption, console, keep_inputs, parse_payload, read_design
from plant.errors import SpecError

#: payload points when --payload is not given and the spec's range is not a single mass
DEFAULT_POINTS = 71


def sweep(
    spec: Annotated[Path, typer.Argument(help="Spec file (TOML); plant.uncertainty gives the Monte Carlo ranges.")],
    payload: Annotated[Optional[str], typer.Option(help="Payloads MIN:MAX:POINTS in kg, e.g. 5:40:71 (default: the "
                                                   f"spec's payload min:max with {DEFAULT_POINTS} points).")] = None,
    samples: Annotated[int, typer.Option(help="Monte Carlo samples per payload (uniform over plant.uncertainty); "
                                         "0: nominal sweep only.", min=0, max=1_000_000)] = 0,
    seed: Annotated[int, typer.Option(help="Seed of the random draws (recorded in the outputs).", min=0)] = 0,
    csv: Annotated[Optional[Path], typer.Option("--csv", help="Write one row per payload (percentiles, worst "
                                                "case; units in the column names) to this CSV file.")] = None,
    design_file: Annotated[Optional[Path], typer.Option("--design", help="Sweep a design: the JSON of gantry synth "
                                                        "--json (its gains and drive filters) instead of the "
                                                        "spec's controller values.")] = None,
    plant_from: PlantFromOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")] = False,
) -> None:
    """Margins and bandwidth across payloads, with Monte Carlo over the spec's uncertainty ranges."""
    from design.loop.sweep import monte_carlo_sweep
    from design.views.console import print_story
    from design.views.design_story import sweep_story
    from design.views.json import print_json, sweep_check_to_dict, sweep_csv, sweep_to_dict
    from design.views.progress import LazyProgress
    from design.workflows import load_problem
    from plant.host.files import atomic_write_text, is_stdout

    keep_inputs({"--csv": csv}, [spec, design_file, plant_from], json=as_json)
    problem = load_problem(spec, plant_from=plant_from).loop
    source = "the spec's controller values"
    if design_file is not None:
        problem, controller, _ = read_design(design_file, problem)
        source = f"the design {design_file}"
    if payload is not None:
        masses = parse_payload(payload)
    else:
        rng = problem.plant.payload_kg
        masses = rng.grid(DEFAULT_POINTS if rng.max > rng.min else 1)
    progress = LazyProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        result = monte_carlo_sweep(problem, payload_kg=masses, samples=samples, seed=seed, progress=progress,
                                   controller=controller if design_file is not None else None)
    except SpecError as exc:
        raise SpecError(f"{spec}: {exc}") from None
    finally:
        progress.close()
    check = result.check(problem.requirements)
    if as_json:
        print_json({**sweep_to_dict(result), "gains_source": source, **sweep_check_to_dict(check, result)})
    else:
        print_story(console, sweep_story(result, check, source))
    if csv is not None:         # the file last: a stop while the tables print leaves no file behind
        atomic_write_text(csv, sweep_csv(result))
        if not as_json and not is_stdout(csv):
            print(f"Wrote {csv}")       # plain: after the file, as few calls as possible
