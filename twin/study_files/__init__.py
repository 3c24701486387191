"""Study files shipped with rfp-twin: ``rfp-twin study run NAME`` finds ``NAME.toml`` here.

``sim1``, ``sim2``, ``sim3``: Sayres et al. 2021 Simulations 1-3 at full size (Tables 1, 2
and 4); ``*-small``: versions that finish in minutes on a laptop; ``density*``: feasibility
maps for arrays denser than SDSS-V. The format is described in :mod:`rfp_twin.twin.studies.spec`.
"""
