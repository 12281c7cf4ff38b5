"""The paper reproduced (``impactnet reproduce-paper``): its data protocol, its 6-20-18-4 MLP,
its metrics, the diagnostics and the report of Tables 1 and 2 and Figures 5 and 6.

May import ``impactnet.models`` and the other training wings; never fastapi.
"""
