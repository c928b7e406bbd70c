within;
model PendulumFrictionExtras "Test bench: the pendulum's free decay from 0.5 rad with every friction extra on"
  PendulumID.Pendulum pendulum(phi0 = PendulumID.pi + 0.5, w_Sp = 0.3, dk_fwp = 5e-4, dT_Kp = 5e-4, T_Op = 0.01,
    k_dp = 2e-4) "Pendulum with the library's defaults and the extras";
equation
  pendulum.a = 0;
  annotation (Documentation(info = "<html>
<p>The Pendulum class with friction extras (pendfmu's README, section Friction law extras): Stribeck speed
w_Sp = 0.3 rad/s, asymmetries dk_fwp = 5e-4 N.m.s and dT_Kp = 5e-4 N.m, offset torque
T_Op = 0.01 N.m and air drag k_dp = 2e-4 N.m.s2, released at rest 0.5 rad from hanging
with the pivot still, for tests/test_friction_extras.py to compare with the Pendulum FMU.
The extras are set here: rumoca treats w_Sp, which selects an if-branch, as structural.</p>
</html>"));
end PendulumFrictionExtras;
