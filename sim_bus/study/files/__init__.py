"""Study files (:mod:`~sim_bus.study.files.studyfile`), the run's manifest
(:mod:`~sim_bus.study.files.manifest`) and running one on the engine
(:mod:`~sim_bus.study.files.studyrun`): ``pacc study --config``."""
