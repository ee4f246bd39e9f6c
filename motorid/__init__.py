"""motorid: nonlinear modelling and online identification of bidirectional DC motor drives."""

__version__ = "0.1.0"
