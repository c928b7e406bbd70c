within PendulumID.Examples;
model RigBackDrivable "The coupled rig with a back-drivable screw (eta > 0.5): the pendulum pushes the cart"
  extends PendulumID.Examples.Rig(eta = 0.8);
  annotation (
    experiment(StopTime = 3.0, Interval = 1e-3, Tolerance = 1e-8),
    Documentation(info = "<html>
<p><a href=\"modelica://PendulumID.Examples.Rig\">Rig</a> with eta = 0.8: the cart's
active force has the back-drive term A(eta) m_p l (w^2 sin(phi) - alpha cos(phi)),
A(0.8) = 0.75, so the cart and the pendulum form an algebraic loop (a linear one, in the
two accelerations, while both slide).</p>
</html>"));
end RigBackDrivable;
