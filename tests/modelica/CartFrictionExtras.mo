within;
model CartFrictionExtras "Test bench: the paper's Fig. 3 mass as the Cart, with every friction extra on: v_Sc = 0.05 m/s, dk_fwc = 0.5 N.s/m, dF_Kc = 0.1 N, F_Oc = 0.15 N"
  PendulumID.Cart cart(m_c = 0.5, m_p = 0.0, eta = 1.0, k_M = 1.0, k_D = 1.0, k_fwc = 2.0, F_Kc = 0.3, F_Sc = 0.8,
    v_Sc = 0.05, dk_fwc = 0.5, dF_Kc = 0.1, F_Oc = 0.15) "The cart as a 0.5 kg mass whose current is the force in newtons";
equation
  cart.I = sin(2*PendulumID.pi*time/0.63);
  cart.u = 0 "the command path (README, Drives) is not used";
  cart.phi = PendulumID.pi;
  cart.w = 0;
  cart.alpha = 0;
  annotation (Documentation(info = "<html>
<p>The Cart class with friction extras (pendfmu's README, section Friction law extras) under the force
sin(2 pi t / 0.63 s) of the paper's friction test, for tests/test_friction_extras.py to
compare with the Cart FMU. The extras are set here, not by a simulation override: rumoca
treats v_Sc, which selects an if-branch, as a structural parameter.</p>
</html>"));
end CartFrictionExtras;
