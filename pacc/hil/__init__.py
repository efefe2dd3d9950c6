"""A person in the loop: the paper's experiment driven from a browser page.

The harness room (like :mod:`pacc.study`): it wires the simulator's world, the ordinary ECU
and the cloud around a person whose pedals and buttons come from a web page
(:mod:`pacc.hil.server`) instead of a synthetic driver.

- :mod:`~pacc.hil.human`: the person's pedals and HMI buttons as the world's driver;
- :mod:`~pacc.hil.loop`: one drive (world + bus + ECU), lockstep or real time;
- :mod:`~pacc.hil.plan`: the paper's protocol for one participant, the Latin square;
- :mod:`~pacc.hil.session`: a participant's session folder, resumable;
- :mod:`~pacc.hil.records`: the session folder's ``manifest.json`` and drive records;
- the vehicle–cloud link is the study's (:class:`pacc.study.loop.StudyCloud`);
- :mod:`~pacc.hil.server`: the FastAPI + WebSocket app serving the driving page (``static/``:
  ``hil.js`` the participant's controls and overlays, ``road.js`` the road and cluster);
- :mod:`~pacc.hil.report`: Table I from the session folders.
"""
