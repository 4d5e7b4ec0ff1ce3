"""Design studies and their optimization: study schema, the CasADi NLP, Pareto fronts."""
