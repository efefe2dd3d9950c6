"""A person in the loop (issue 19): the paper's experiment driven from a browser page.

The harness room (like :mod:`sim_bus.study`): it wires the simulator's world, the ordinary ECU
and the cloud around a person whose pedals and buttons come from a web page
(:mod:`sim_bus.hil.server`) instead of a synthetic driver.

- :mod:`~sim_bus.hil.human`: the person's pedals and HMI buttons as the world's driver;
- :mod:`~sim_bus.hil.loop`: one drive (world + bus + ECU), lockstep or real time;
- :mod:`~sim_bus.hil.plan`: the paper's protocol for one participant, the Latin square;
- :mod:`~sim_bus.hil.session`: a participant's session folder, resumable;
- :mod:`~sim_bus.hil.manifest`: the session folder's ``manifest.json`` (plan, steps done, events);
- :mod:`~sim_bus.hil.records`: what a finished drive leaves in the session folder;
- :mod:`~sim_bus.hil.cloud`: the session's vehicle–cloud link (upload, learn, fine-tune);
- :mod:`~sim_bus.hil.server`: the FastAPI + WebSocket app serving the driving page;
- :mod:`~sim_bus.hil.report`: Table I from the session folders.
"""
