within PendulumID;
model CurrentLoop "Current control loop of the DC motor: slope-limited first-order lag plus PWM ripple (paper Eq. 1)"
  parameter Real T_i(unit = "s") = 0.3e-3 "Equivalent time constant of the current control loop";
  parameter Real dIdt_max(unit = "A/s") = 2500.0 "Maximum slope of the current";
  parameter Real a_h(unit = "A") = 0.0 "Amplitude of the PWM ripple harmonic on the output current";
  parameter Real f_h(unit = "Hz") = 0.0 "Frequency of the PWM ripple harmonic";
  parameter Real phase_h(unit = "rad") = 0.0 "Phase of the PWM ripple harmonic";
  parameter Real I0(unit = "A") = 0.0 "Initial current";
  input Real I_c(unit = "A", start = 0.0) "Command current";
  output Real I(unit = "A") "Motor current, ripple included";
  output Real I_mean(unit = "A", start = I0, fixed = true)
    "Current without ripple (state of the lag): what drives the motor's torque";
  Integer mode "Slope limit: -1 falling at -dIdt_max, 0 linear lag, +1 rising at dIdt_max";
  Boolean saturated "The slope limit is active";
protected
  final parameter Real band(unit = "A") = T_i*dIdt_max "Current error at which the slope limit begins";
equation
  assert(T_i > 0 and dIdt_max > 0, "CurrentLoop: T_i and dIdt_max must be > 0");
  mode = if I_c - I_mean > band then 1 elseif I_c - I_mean < -band then -1 else 0;
  saturated = mode <> 0;
  der(I_mean) = if mode == 0 then (I_c - I_mean)/T_i else mode*dIdt_max;
  I = I_mean + a_h*sin(2*pi*f_h*time + phase_h);
  annotation (Documentation(info = "<html>
<p>The converter's current control loop as a first-order lag whose slope is limited
(paper Eq. 1; pendfmu's docs/user-guide/model.md):</p>
<pre>
  dI_mean/dt = dIdt_max sat((I_c - I_mean) / (T_i dIdt_max)),   sat(z) = max(-1, min(1, z))
  I = I_mean + a_h sin(2 pi f_h time + phase_h)
</pre>
<p>The corner of sat() is written as the mode <code>mode</code> (-1, 0, +1) of an
if-expression, whose relations are state events for a Modelica tool: the ramp ends
and the exponential begins at a located instant, as in the FMU.</p>
<p>The FMU's parameter <code>solver_step</code> and local <code>t_mode</code> do not
exist here (see the package documentation).</p>
</html>"));
end CurrentLoop;
