"""Study files (:mod:`~pacc.study.files.studyfile`: TOML to a
:class:`~pacc.study.spec.StudySpec`) and the run's manifest (:mod:`~pacc.study.files.manifest`):
``pacc study --config``."""
