"""Protection of the service against its clients: the process memory budget, saturation of
the compute slots, body-read deadlines, upload spooling and guarded bundle reloads.

May import the standard library, NumPy and ``impactnet.service`` settings; never torch.
"""
