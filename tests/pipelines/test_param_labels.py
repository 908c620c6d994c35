"""Every pipeline parameter has a label and a unit, and the unit agrees with the one its name carries."""

import re
from pathlib import Path

from ldvsurvey.pipelines import labels
from ldvsurvey.pipelines.labels import PARAM_LABELS, SUFFIX_UNIT, label_unit, param_label
from ldvsurvey.pipelines.registry import PIPELINES


def test_every_parameter_has_a_label():
    missing = sorted({q.name for p in PIPELINES.values() for q in p.params} - set(PARAM_LABELS))
    assert not missing, f"add these to ldvsurvey/pipelines/labels.py: {missing}"


def test_units_agree_with_the_names():
    for name, (label, unit) in PARAM_LABELS.items():
        assert "_" not in label.replace("φ_L", "").replace("η_L", "").replace("k_η", ""), name
        suffix = name.rsplit("_", 1)[-1]
        if suffix in SUFFIX_UNIT:
            assert unit == label_unit(name)[1], (name, unit)
    assert param_label("ldv_pitch_k_rad_per_mps2") == ("LDV pitch compliance k_η", "rad/(m/s²)")
    assert param_label("new_thing_x") == ("New thing x", "")


#: every name in the code ending in mps2 whose value is a compliance in rad per m/s² (the parameter's
#: description says so), not an acceleration; each other ..._mps2 name is in m/s²
RAD_PER_MPS2 = {"ldv_pitch_k_rad_per_mps2", "ldv_pitch_k_rad_per_mps2_sigma", "pitch_k_rad_per_mps2"}
RAD_PER_MPS2 |= {"squat_rad_per_mps2", "roll_rad_per_mps2"}  # the simulator's truth


def test_every_mps2_name_reads_right():
    """One unit table (labels.SUFFIX_UNIT) labels parameters and summary keys: an ..._mps2 name is in
    m/s², a ..._rad_per_mps2 one in rad/(m/s²); every such name the package writes is listed here."""
    src = "".join(p.read_text() for p in (Path(labels.__file__).parents[1]).rglob("*.py"))
    names = set(re.findall(r'"([a-z0-9_]+_mps2(?:_[a-z0-9]+)*)"', src)) - {"rad_per_mps2"}
    assert RAD_PER_MPS2 <= names and "drift_mps2" in names
    for n in sorted(names):
        want = "rad/(m/s²)" if n in RAD_PER_MPS2 else "m/s²"
        assert label_unit(n)[1] == want, n
        if n in PARAM_LABELS:
            assert PARAM_LABELS[n][1] == want, n
    helps = {q.help for p in PIPELINES.values() for q in p.params if q.name == "ldv_pitch_k_rad_per_mps2"}
    assert helps and all("rad per m/s²" in h for h in helps)
    assert label_unit("ldv_pitch_k_rad_per_mps2_sigma") == ("ldv pitch k (sigma)", "rad/(m/s²)")
    assert label_unit("accel_noise_ug_rthz") == ("accel noise", "µg/√Hz")
    assert label_unit("heading_sigma_deg") == ("heading sigma", "°")
    assert label_unit("ldv_pitch_compliance_deg_per_g") == ("ldv pitch compliance", "°/g")
    assert label_unit("line_slopes_mgal_per_km") == ("line slopes", "mGal/km")


def test_units_agree_with_the_descriptions():
    # the description (the model's own words) names the same unit as the label
    words = {"s": " s", "m": " m", "°": "degree", "Hz": "Hz", "′": "arcmin", "m/s": "m/s"}
    for p in PIPELINES.values():
        for q in p.params:
            unit = PARAM_LABELS[q.name][1]
            if unit in words and q.help:
                assert words[unit] in q.help or unit in q.help, (p.name, q.name, unit, q.help)
