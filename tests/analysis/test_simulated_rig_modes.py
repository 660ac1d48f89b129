"""identify() (LSCF with the stabilisation check) on a burst-random FRF test of the simulated rig
(impacts off), block by block through rigtools.analysis.point.analyze_frf_test: the active blade's first
three flexural frequencies within 0.5 % of the simulated test article's own FEM values, and the
natural-frequency table beside the nominal FEM."""

import numpy as np

from rigtools.analysis.correlation import natural_frequency_table
from rigtools.analysis.frf import FRFMethod
from rigtools.analysis.point import analyze_frf_test


def test_burst_random_on_the_simulated_rig_finds_the_test_articles_frequencies(burst_frf_test):
    from rigtools.config import load_rig
    from rigtools.sim.modal import flexural_frequencies
    from rigtools.sim.rig_model import build_rig_model

    cfg = load_rig()
    rig, fs, period, samples = burst_frf_test
    names = [s.name for s in cfg.daq.input_specs()]
    n = samples.shape[1]
    data = {name: samples[i] for i, name in enumerate(names)}
    step = 30000
    blocks = ({k: v[i : i + step] for k, v in data.items()} for i in range(0, n, step))
    res = analyze_frf_test(
        blocks,
        fs,
        frf_method=FRFMethod("burst", int(period * fs)),
        responses=("active_shroud_accel",),
        f_min=10,
        f_max=1800,
        n_modes=3,
    )
    ident = res.modes["active_shroud_accel"]
    em = np.array([m.frequency_hz for m in ident.modes])
    truth = flexural_frequencies(rig.rig_model().active, 3)
    assert em.size == 3, ident.notes
    np.testing.assert_allclose(em, truth, rtol=5e-3)
    nominal = flexural_frequencies(build_rig_model(cfg.to_params()).active, 3)
    table = natural_frequency_table({"active": nominal}, em={"active": em})
    assert np.all((table.fem_vs_em_pct > 1.0) & (table.fem_vs_em_pct < 3.2))
