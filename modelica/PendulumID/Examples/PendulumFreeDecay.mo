within PendulumID.Examples;
model PendulumFreeDecay "Identification experiment 3: the pendulum swings freely from a released angle, the cart still"
  PendulumID.Pendulum pendulum(phi0 = pi + 0.5) "Pendulum released 0.5 rad from hanging";
equation
  pendulum.a = 0;
  annotation (
    experiment(StopTime = 10.0, Interval = 1e-3, Tolerance = 1e-8),
    Documentation(info = "<html>
<p>The pendulum, its pivot held still (a = 0), released at rest 0.5 rad from the hanging
position: a damped oscillation whose amplitude decays by the viscous k_fwp and,
linearly, by the Coulomb T_Kp, until stiction T_Sp holds it at a turning point.</p>
</html>"));
end PendulumFreeDecay;
