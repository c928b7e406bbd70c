within;
package PendulumID "Inverted-pendulum rig: current loop, cart and pendulum with stick-slip friction"
  constant Real pi = 3.14159265358979323846 "Ratio of a circle's circumference to its diameter";

  annotation (
    version = "0.1.0",
    Documentation(info = "<html>
<p>The Modelica twin of pendfmu's component FMUs <code>CurrentLoop</code>, <code>Cart</code>
and <code>Pendulum</code> (paper Eq. 1-8, specified in pendfmu's
<code>docs/user-guide/model.md</code>). Every parameter, input and output has the name, unit,
default and description of the FMU variable tables in <code>pendfmu/components.py</code>; a
test in pendfmu compares the two.</p>
<ul>
<li><a href=\"modelica://PendulumID.StickSlip\">StickSlip</a>: the three-mode stick-slip
friction (viscous, Coulomb, stiction) of one joint, shared by the cart and the pendulum.</li>
<li><a href=\"modelica://PendulumID.CurrentLoop\">CurrentLoop</a>: slope-limited
first-order current loop with PWM ripple.</li>
<li><a href=\"modelica://PendulumID.Cart\">Cart</a>: cart on a lead screw.</li>
<li><a href=\"modelica://PendulumID.Pendulum\">Pendulum</a>: pendulum on the cart's pivot.</li>
<li><a href=\"modelica://PendulumID.Examples\">Examples</a>: the paper's friction test
(Fig. 3), the coupled rig and the identification experiments.</li>
</ul>
<p>Differences from the FMUs: the FMU-only parameter <code>solver_step</code> (the step
of the FMU's internal fixed-step integrator) and the local <code>t_mode</code> (the time
of the last mode change, which a Modelica tool records as an event in its result) do not
exist here. The library needs no other library; units are plain <code>unit</code>
attributes.</p>
</html>"));
end PendulumID;
