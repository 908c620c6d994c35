"""The product's own simulator: truth trajectories, exact IMU increments, LDV and GNSS.

Ideal scenarios (``catalog.drive``, ``height``, ``gravity``, ``dov``, ``vessel``) build the world the
way the pipelines assume it; the ``realistic_*`` family adds the effects real drives have, one
switch each (``effects.Effects``, ``effects.effect_names()``), modelled in ``body.py``,
``pointmass.py``, ``imuerrors.py``, ``turntable.py``, ``gnsseffects.py`` and ``ldvfaults.py``; what
only the simulation knows is in ``truth.py``.
"""
