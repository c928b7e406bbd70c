within PendulumID.Examples;
model Rig "The three components coupled: current loop -> cart -> pendulum (and back, for a back-drivable screw)"
  parameter Real eta(unit = "1") = 0.4 "Efficiency of the lead screw; above 0.5 the pendulum back-drives the cart";
  parameter Real m_p(unit = "kg") = 0.2 "Mass of the pendulum";
  parameter Real l(unit = "m") = 0.3 "Distance from the pivot to the pendulum's centre of mass";
  parameter Real I_on(unit = "A") = 2.0 "Command current during the pulse";
  parameter Real t_on(unit = "s") = 0.1 "Start of the command current pulse";
  parameter Real t_off(unit = "s") = 0.4 "End of the command current pulse";
  PendulumID.CurrentLoop currentLoop "Current loop of the motor";
  PendulumID.Cart cart(eta = eta, m_p = m_p, l = l) "Cart on the lead screw";
  PendulumID.Pendulum pendulum(m_p = m_p, l = l) "Pendulum on the cart";
equation
  currentLoop.I_c = if time >= t_on and time < t_off then I_on else 0;
  cart.I = currentLoop.I_mean;
  cart.u = 0 "the command path (k_u, README Drives) is not used: the current drives";
  pendulum.a = cart.a;
  if eta > 0.5 then
    // back-drivable screw: the pendulum's reaction acts on the cart (an algebraic loop)
    cart.phi = pendulum.phi;
    cart.w = pendulum.w;
    cart.alpha = pendulum.alpha;
  else
    // self-locking screw: the cart ignores these inputs; bind them to their defaults
    cart.phi = pi;
    cart.w = 0;
    cart.alpha = 0;
  end if;
  annotation (
    experiment(StopTime = 3.0, Interval = 1e-3, Tolerance = 1e-8),
    Documentation(info = "<html>
<p>The rig of the paper's coupled experiment: a pulse of the command current
I_c = I_on for t_on &le; t &lt; t_off drives the current loop, whose current drives the
cart, whose acceleration moves the pendulum's pivot:</p>
<pre>
  cart.I = currentLoop.I_mean,   pendulum.a = cart.a
  eta &gt; 0.5:  cart.phi = pendulum.phi, cart.w = pendulum.w, cart.alpha = pendulum.alpha
</pre>
<p>With a self-locking screw (eta &le; 0.5, the paper's rig) the cart does not feel the
pendulum and its pendulum inputs are bound to constants. With eta &gt; 0.5 the cart's
active force depends on the pendulum's angular acceleration, which depends on the cart's
acceleration: a linear algebraic loop that the Modelica tool solves. <code>eta</code> is
a structural parameter: it selects the equations.</p>
</html>"));
end Rig;
