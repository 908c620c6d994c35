"""Every pipeline parameter has a label and a unit, and the unit agrees with the one its name carries."""

from ldvsurvey.pipelines.labels import PARAM_LABELS, SUFFIX_UNIT, param_label
from ldvsurvey.pipelines.registry import PIPELINES


def test_every_parameter_has_a_label():
    missing = sorted({q.name for p in PIPELINES.values() for q in p.params} - set(PARAM_LABELS))
    assert not missing, f"add these to ldvsurvey/pipelines/labels.py: {missing}"


def test_units_agree_with_the_names():
    for name, (label, unit) in PARAM_LABELS.items():
        assert "_" not in label.replace("φ_L", "").replace("η_L", "").replace("k_η", ""), name
        suffix = name.rsplit("_", 1)[-1]
        if suffix in SUFFIX_UNIT and name != "ldv_pitch_k_rad_per_mps2":
            assert unit == SUFFIX_UNIT[suffix], (name, unit)
    assert param_label("ldv_pitch_k_rad_per_mps2") == ("LDV pitch compliance k_η", "rad/(m/s²)")
    assert param_label("new_thing_x") == ("New thing x", "")


def test_units_agree_with_the_descriptions():
    # the description (the model's own words) names the same unit as the label
    words = {"s": " s", "m": " m", "°": "degree", "Hz": "Hz", "′": "arcmin", "m/s": "m/s"}
    for p in PIPELINES.values():
        for q in p.params:
            unit = PARAM_LABELS[q.name][1]
            if unit in words and q.help:
                assert words[unit] in q.help or unit in q.help, (p.name, q.name, unit, q.help)
