"""The humanoid (HRP-2) walking and skating steps: the GPM step problem (``step``), the
walk/skate plans and their solution (``motion``), the independent checks and library entries."""
