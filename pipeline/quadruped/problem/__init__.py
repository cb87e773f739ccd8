"""The quadruped's push-off NLP: its knots, bounds, cost and constraint terms, guesses, the solve
and its retry ladder."""
