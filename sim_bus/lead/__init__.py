"""The lead vehicle: what the tracked vehicle ahead of the ego does over a drive.

- :mod:`sim_bus.lead.profile` — ``LeadProfile`` (the lead's speed, 10 Hz) and ``LeadEvent``;
- :mod:`sim_bus.lead.scenarios` — profiles from the shipped OpenACC data, the canonical set
  (``python -m sim_bus.lead list|export``);
- :mod:`sim_bus.lead.profile_csv` — a lead profile as a CSV file (write, read, check);
- :mod:`sim_bus.lead.events` — road scenarios: cut-in, cut-out, lead loss, stop-and-go.
"""
