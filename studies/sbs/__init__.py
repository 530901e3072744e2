"""Virtual fixtures for skull-base surgery (Kouskoulas et al., HSCC 2013): the ctrl1/ctrl2 models, the
verified virtual-fixture kernel (`fixture.VirtualFixture`, numpy; `native` for its C step), its monitor
and demo, and the kernels generated from ctrl2 (`generated/`)."""
