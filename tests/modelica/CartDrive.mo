within;
model CartDrive "Test bench: the paper's Fig. 3 mass as the Cart, driven through the command u with a back-EMF and an electrical lag: k_u = 1.2 N, k_emf = 1.5 N.s/m, tau_e = 0.02 s"
  PendulumID.Cart cart(m_c = 0.5, m_p = 0.0, eta = 1.0, k_M = 1.0, k_D = 1.0, k_fwc = 2.0, F_Kc = 0.3, F_Sc = 0.8,
    k_u = 1.2, k_emf = 1.5, tau_e = 0.02) "The cart as a 0.5 kg mass driven by the command u, no current";
equation
  cart.I = 0;
  cart.u = sin(2*PendulumID.pi*time/0.63);
  cart.phi = PendulumID.pi;
  cart.w = 0;
  cart.alpha = 0;
  annotation (Documentation(info = "<html>
<p>The Cart class with the drive extras (README, Drives) under the command
sin(2 pi t / 0.63 s) of the paper's friction test, for tests/test_drives.py to compare with
the Cart FMU. tau_e selects an if-branch, so it is set here, not by a simulation override.</p>
</html>"));
end CartDrive;
