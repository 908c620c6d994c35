"""The ``gravity`` pipeline: strapdown gravity from SINS/2-D LDV (or SINS/GNSS), its lines and network.

``pipeline`` holds the parameters, the applicability check and ``run``; the stages it calls are
``chains`` (the raw δg chains), ``drift`` (stop ties), ``report`` (filtering, lines, coincidence,
floors), ``floor`` (the drift's share of the floor), ``network`` (base ties, several logs, crossovers)
and ``map`` (the gridded map of the adjusted network).
"""

from ldvsurvey.pipelines.gravity.pipeline import PIPELINE, GravityParams, applicable, run

__all__ = ["PIPELINE", "GravityParams", "applicable", "run"]
