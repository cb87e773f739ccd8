"""The quadruped's transitions: their build tasks, and the physical twin's judgement of their
candidates."""
