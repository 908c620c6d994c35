"""What the job page leads with: a job's headline figures, and the human label of every key it shows.

The figures and their labels are the survey report's (:data:`ldvsurvey.api.report.HEADLINES`), so the
page and the report a client receives say the same; the labels of summary keys come from their unit
suffixes (:func:`ldvsurvey.pipelines.labels.label_unit`), those of parameters from
:data:`ldvsurvey.pipelines.labels.PARAM_LABELS`.
"""

from __future__ import annotations

from ldvsurvey.api.report import HEADLINES, fmt, summary_value
from ldvsurvey.pipelines.labels import label_unit, param_label

#: headline figures a user may hold to a specification: |value| ≤ the specification passes
SPECIFIABLE = {
    "gravity": {"total_mgal", "crossover_mgal"},
    "height": {"std_error_m_fix4", "max_error_m_fix4", "std_error_m", "max_error_m"},
    "navigate": {"rms_horizontal_error_m", "max_horizontal_error_m", "max_height_error_m"},
}


def headlines(pipeline: str, summary: dict | None) -> list[dict]:
    """The headline figures present in ``summary``: key (dotted path), label, value, unit, the value
    as text with its unit, and whether a specification may bound it."""
    out = []
    for key, label in HEADLINES.get(pipeline, []):
        v = summary_value(summary or {}, key)
        if v is None or isinstance(v, (dict, list)):
            continue
        unit = label_unit(key.rsplit(".", 1)[-1])[1]
        out.append(
            {
                "key": key,
                "label": label,
                "value": v,
                "unit": unit,
                "text": fmt(v, unit),
                "specifiable": key in SPECIFIABLE.get(pipeline, set()),
            }
        )
    return out


#: words written as people write them in a label
ACRONYMS = {w: w.upper() for w in ("fir", "ldv", "gnss", "imu", "rms", "dov", "sins", "rtk", "egm", "utc", "sha256")}
ACRONYMS |= {"chi2": "χ²", "xi": "ξ", "eta": "η", "dof": "degrees of freedom", "mgal": "mGal", "pct": "%"}


def human(label: str) -> str:
    """'n lines compared' → 'Number of lines compared'; 'fir length' → 'FIR length'."""
    words = [ACRONYMS.get(w, w) for w in label.split(" ")]
    if words and words[0] == "n" and len(words) > 1:
        words = ["number", "of"] + words[1:]
    out = " ".join(words)
    # a symbol keeps its case (ξ is not Ξ)
    return out[:1].upper() + out[1:] if out[:1].isascii() else out


def labels(summary: dict | None, parameters: dict | None) -> dict[str, dict]:
    """{key: {label, unit}} for every key of the summary (nested ones included) and the parameters."""
    out: dict[str, dict] = {}

    def walk(x):
        if isinstance(x, dict):
            for k, v in x.items():
                if k not in out:
                    lab, unit = label_unit(k)
                    out[k] = {"label": human(lab), "unit": unit}
                walk(v)
        elif isinstance(x, list):
            for v in x[:50]:
                walk(v)

    walk(summary or {})
    for k in list(parameters or {}) + list((summary or {}).get("parameters") or {}):
        lab, unit = param_label(k)
        out[k] = {"label": lab, "unit": unit}
    return out
