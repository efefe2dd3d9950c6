"""Study files (:mod:`~pacc.study.files.studyfile`), the run's manifest
(:mod:`~pacc.study.files.manifest`) and running one on the engine
(:mod:`~pacc.study.files.studyrun`): ``pacc study --config``."""
