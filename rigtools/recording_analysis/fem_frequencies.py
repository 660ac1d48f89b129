"""The natural frequencies identified in a recording beside this rig's FEM and analytical ones
(the paper's Table 2), and the simulated test article's when the recording was made on the
simulated rig."""

from __future__ import annotations

import math

import numpy as np

from rigtools.analysis.correlation import natural_frequency_table
from rigtools.errors import UserError
from rigtools.recording import RecordingError, open_recording
from rigtools.recording_analysis.broadband import BLADE_OF, PASSIVE_NOT_EXCITED, PROCEDURE_FRF
from rigtools.recording_analysis.results import RecordingAnalysis
from rigtools.sim.natural_frequencies import analytical_natural_frequencies
from rigtools.sim.natural_frequencies import reduced_natural_frequencies as natural_frequencies
from rigtools.sim.reduction import reduce_rig_model, reduced_system
from rigtools.sim.rig_model import build_rig_model


def identified_frequencies(analysis: RecordingAnalysis) -> dict[str, list[float]]:
    """``{blade: natural frequencies}`` identified from the shroud responses of the broadband
    points (the first point with modes for each blade)."""
    em: dict[str, list[float]] = {}
    for p in analysis.broadband:
        for r in p.frf.responses:
            blade = BLADE_OF.get(r)
            modes = p.frf.modes[r].modes
            if blade and modes and blade not in em:
                em[blade] = sorted(m.frequency_hz for m in modes)
    return em


def model_frequencies(rig_config, n_modes: int = 3) -> dict[str, dict[str, list[float]]]:
    """Flexural natural frequencies of both blades of a rig: ``{"fem": ..., "am": ...,
    "article": ...}`` with ``{blade: [Hz, ...]}`` each. ``fem``: the reduced FE model
    (:mod:`rigtools.sim.natural_frequencies`); ``am``: the exact Euler-Bernoulli solution; ``article``: the simulated rig's test
    article (``[test_article]`` applied to the nominal rig as :class:`rigtools.drivers.simulated.SimulatedRig`
    does, reduced as its vibro-impact physics does)."""
    params = rig_config.to_params()
    fem = natural_frequencies(reduced_system(params, "fem"))
    am = analytical_natural_frequencies(params, n_modes)
    out = {
        "fem": {b: [float(x) for x in fem[b][:n_modes]] for b in fem},
        "am": {b: [float(x) for x in am[b]] for b in am},
    }
    article = getattr(rig_config, "test_article", None)
    if article is not None:
        art = natural_frequencies(reduce_rig_model(build_rig_model(article.to_params().apply(params))))
        out["article"] = {b: [float(x) for x in art[b][:n_modes]] for b in art}
    return out


def frequency_table(analysis: RecordingAnalysis, path, n_modes: int = 3) -> list[dict] | None:
    """The paper's Table 2 for a broadband recording: per blade and mode FEM, AM, EM (identified)
    and their differences in % (:func:`rigtools.analysis.correlation.natural_frequency_table`), with the
    simulated test article's own frequency and EM's difference from it when the recording was
    made on the simulated rig. None if nothing was identified or the rig cannot be read."""
    em = identified_frequencies(analysis)
    if not em:
        return None
    try:
        with open_recording(path) as rec:
            cfg = rec.rig_config()
    except (RecordingError, UserError) as exc:
        analysis.notes.append(f"no FEM/AM natural-frequency table: the recording's rig is unreadable ({exc})")
        return None
    models = model_frequencies(cfg, n_modes)
    em_full = {b: em.get(b, []) for b in models["fem"]}
    table = natural_frequency_table(models["fem"], em_full, models["am"], n_modes=n_modes)
    rows = table.to_dict("records")
    if analysis.backend == "simulated" and "article" in models:
        for r in rows:
            vals = models["article"].get(r["blade"], [])
            ref = vals[r["mode"] - 1] if r["mode"] <= len(vals) else float("nan")
            r["article_hz"] = ref
            r["em_vs_article_pct"] = 100 * (r["em_hz"] - ref) / ref if not math.isnan(ref) else float("nan")
    shaker_driven = analysis.procedure in PROCEDURE_FRF
    for blade in models["fem"]:
        if blade == "passive" and blade not in em and shaker_driven:
            analysis.notes.append(f"passive blade: {PASSIVE_NOT_EXCITED}; its EM column is empty")
        elif blade not in em:
            analysis.notes.append(
                f"{blade} blade: no modes identified in this recording (its shroud "
                "response did not follow the force); its EM column is empty"
            )
    return [{k: (float(v) if isinstance(v, (np.floating, float)) else v) for k, v in r.items()} for r in rows]
