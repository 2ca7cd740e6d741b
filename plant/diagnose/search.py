"""The one model search of a diagnosis, whatever the kind of data; the kind provides the fitter.

``fit_models`` fits the base model and every combination of up to ``max_effects`` effects of a pool
(a model search, not a greedy path). A model is fitted once every model it contains with one effect
less has been (its parents, handed to the fitter, which may start from their optima so that a nested
model never fits worse than its parent); the fitter may instead say why it cannot be fitted.
``select_model`` chooses among the fits by BIC and consistency with the noise; ``path_to`` gives the
models from the base to the selected one, each adding the effect that lowers BIC most.

Selection (Kass & Raftery 1995: an effect is kept only on very strong evidence): the model of lowest
BIC among those consistent with the noise (among all, when none is); replaced by a simpler one while
that one is within ``ACCEPT_DELTA_BIC``: a model it contains, or one with fewer parameters (or as many
with simpler physics: ``Effect.complexity``) that is itself consistent with the noise; then, among
the models within ``TIE_DELTA_BIC``, the one with the fewest effects, parameters and the simplest
physics. A model consistent with the noise is never traded for one that is not.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TypeVar

from plant.diagnose.evidence import ACCEPT_DELTA_BIC, TIE_DELTA_BIC
from plant.physics.effects import EFFECTS

#: a model: the names of its effects, the base model's first
Model = tuple[str, ...]
F = TypeVar("F")


def fit_models(base: Model, base_fit: F, pool: Sequence[str], fit: Callable[[Model, list[F]], F | str], *,
               max_effects: int, valid: Callable[[Model], bool] = lambda combo: True,
               progress: Callable[[int, int], None] | None = None) -> tuple[dict[Model, F], dict[Model, str]]:
    """Every model ``base + combo`` (``combo`` up to ``max_effects`` of ``pool``, in pool order, that
    ``valid`` accepts and whose parents were fitted), by ``fit(combo, parents)``; and, by ``combo``, why the
    fitter refused those it returned a reason for. ``progress(done, total)`` hears the combinations tried."""
    fits: dict[Model, F] = {base: base_fit}
    refused: dict[Model, str] = {}
    todo = [combo for size in range(1, max_effects + 1) for combo in itertools.combinations(pool, size)
            if valid(combo)]
    for done, combo in enumerate(todo):
        if progress is not None:
            progress(done, len(todo))
        parents = [fits[p] for p in (base + tuple(c for c in combo if c != n) for n in combo) if p in fits]
        if not parents:
            continue
        result = fit(combo, parents)
        if isinstance(result, str):
            refused[combo] = result
        else:
            fits[base + combo] = result
    if progress is not None:
        progress(len(todo), len(todo))
    return fits, refused


def compatible(combo: Model, base: Model = ()) -> bool:
    """The effects of ``combo`` and ``base`` can stand together (``Effect.excludes``, ``Effect.requires_any``)."""
    names = set(combo) | set(base)
    return all(not names & set(EFFECTS[n].excludes)
               and (not EFFECTS[n].requires_any or bool(names & set(EFFECTS[n].requires_any))) for n in names)


def complexity(model: Model) -> int:
    """How elaborate the physics of a model is (``Effect.complexity`` summed)."""
    return sum(EFFECTS[n].complexity for n in model)


def select_model(bic: Mapping[Model, float], adequate: Mapping[Model, bool],
                 n_params: Mapping[Model, int]) -> Model:
    """The selected model (module doc): ``bic``, ``adequate`` (consistent with the noise) and ``n_params``
    by model."""
    def simpler(a: Model, b: Model) -> bool:
        return n_params[a] < n_params[b] or (n_params[a] == n_params[b] and complexity(a) < complexity(b))

    chosen = min((k for k in bic if adequate[k]) if any(adequate.values()) else bic, key=bic.get)
    while True:
        better = [k for k in bic if bic[k] < bic[chosen] + ACCEPT_DELTA_BIC
                  and (adequate[k] or not adequate[chosen])
                  and (set(k) < set(chosen) or (simpler(k, chosen) and adequate[k]))]
        if not better:
            break
        chosen = min(better, key=lambda k: (n_params[k], complexity(k), len(k), bic[k]))
    ties = [k for k in bic if abs(bic[k] - bic[chosen]) < TIE_DELTA_BIC and (adequate[k] or not adequate[chosen])]
    return min(ties, key=lambda k: (len(k), n_params[k], complexity(k), bic[k]))


def children(models: Iterable[Model], model: Model) -> list[Model]:
    """The models that add one effect to ``model``."""
    return [k for k in models if len(k) == len(model) + 1 and set(model) < set(k)]


def path_to(bic: Mapping[Model, float], base: Model, selected: Model) -> list[Model]:
    """The models from ``base`` to ``selected``, each adding the effect (within ``selected``) whose model has
    the lowest BIC."""
    path = [base]
    while set(path[-1]) != set(selected):
        options = [k for k in children(bic, path[-1]) if set(k) <= set(selected)]
        path.append(min(options, key=bic.get))
    return path
