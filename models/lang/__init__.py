"""The modelling language: terms and formulas, hybrid programs, theorems, printing."""
