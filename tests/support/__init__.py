"""References and fixtures the tests share: implementations kept only to check the package against
(numpy filters, the Opti NMPC, the kinematic simulator, synthetic recordings)."""
