within PendulumID.Examples;
model CartStartStop "Identification experiment 2: the cart, pendulum removed, starts under a current step and brakes to a stop"
  parameter Real I_on(unit = "A") = 5.0 "Command current during the pulse";
  parameter Real t_on(unit = "s") = 0.01 "Start of the command current pulse";
  parameter Real t_off(unit = "s") = 0.3 "End of the command current pulse";
  PendulumID.CurrentLoop currentLoop "Current loop of the motor";
  PendulumID.Cart cart(m_p = 0) "Cart on the lead screw, pendulum removed";
equation
  currentLoop.I_c = if time >= t_on and time < t_off then I_on else 0;
  cart.I = currentLoop.I_mean;
  cart.u = 0 "the command path (k_u, README Drives) is not used: the current drives";
  cart.phi = pi;
  cart.w = 0;
  cart.alpha = 0;
  annotation (
    experiment(StopTime = 0.6, Interval = 1e-4, Tolerance = 1e-8),
    Documentation(info = "<html>
<p>A pulse of the command current (I_on from t_on to t_off) through the current loop:
the cart breaks away when eta k_M k_D I exceeds F_Sc, runs towards the speed where drive
and friction balance, and after the pulse brakes under k_fwc v + F_Kc until it sticks.
The pendulum inputs of the cart are bound to constants (they are unused for m_p = 0).</p>
</html>"));
end CartStartStop;
