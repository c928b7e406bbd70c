within PendulumID;
model StickSlip "Viscous, Coulomb and stiction friction of one joint as a three-mode hybrid model"
  parameter Real m "Inertia of the joint: mass [kg] of a slider, or moment of inertia [kg.m2] of a rotary joint";
  parameter Real k_fw "Viscous friction coefficient [N.s/m or N.m.s]";
  parameter Real F_K "Coulomb (kinetic) friction [N or N.m]";
  parameter Real F_S "Stiction, the maximum static friction [N or N.m]";
  parameter Real v_start = 0 "Initial speed [m/s or rad/s]";
  final parameter Real F_break = max(F_S, F_K) "Breakaway threshold: a joint at rest moves when |F_A| exceeds it";
  input Real F_A "Active force (or torque) on the joint";
  output Real v(start = v_start, fixed = true) "Speed of the joint";
  output Real a "Acceleration of the joint";
  output Real F_F "Friction force (or torque)";
  Integer mode(start = 0) "Friction mode: +1 sliding forward, 0 stuck, -1 sliding backward";
  Boolean stuck "The joint is held by stiction";
equation
  F_F = if mode == 0 then F_A else k_fw*v + F_K*mode;
  a = if mode == 0 then 0 else (F_A - F_F)/m;
  der(v) = a;
  stuck = mode == 0;
  // The initial mode is set in a "when initial()" branch rather than by an initial
  // equation: rumoca 0.10.2 cannot order an initial equation for mode that reads an
  // active force depending on another joint's mode (see modelica/README.md).
  when initial() then
    mode = if v_start > 0 then 1 elseif v_start < 0 then -1
      elseif abs(F_A) <= F_break then 0 elseif F_A >= 0 then 1 else -1;
  elsewhen {pre(mode) == 0 and abs(F_A) > F_break, pre(mode) == 1 and v < 0, pre(mode) == -1 and v > 0} then
    mode = if abs(F_A) <= F_break then 0 elseif F_A >= 0 then 1 else -1;
    reinit(v, 0);
  end when;
  annotation (Documentation(info = "<html>
<p>The friction law of MODEL.md (and of pendfmu's <code>friction.h</code>), with speed
<i>v</i>, active force <i>F_A</i> and inertia <i>m</i>:</p>
<pre>
  m dv/dt = F_A - F_F
  sliding (mode = +1 or -1):  F_F = k_fw v + F_K mode
  stuck   (mode = 0):         F_F = F_A,  v = 0,  dv/dt = 0
</pre>
<p>While stuck the friction holds the whole active force: this is the stiction
min(F_S, |F_A|) sgn(F_A) of the paper for every |F_A| the joint stays stuck at.</p>
<p>Mode changes are state events of the <code>when</code> equation (a Modelica tool
locates them by root finding on the crossing functions):</p>
<ul>
<li>sliding to stuck: the speed crosses 0 (mode*v &lt; 0) and |F_A| &le; F_break; if
|F_A| &gt; F_break the joint reverses instead (new mode sgn(F_A));</li>
<li>stuck to sliding: |F_A| exceeds F_break = max(F_S, F_K), in the direction
sgn(F_A), with sgn(0) = +1.</li>
</ul>
<p>The speed is reset to exactly 0 (<code>reinit</code>) at every mode change; a
breakaway starts from v = 0 anyway. With F_S &lt; F_K a joint that broke away at F_S
would decelerate at once and stop again, so the threshold is max(F_S, F_K).</p>
<p>The initial mode follows from the initial speed (its sign) or, at rest, from the
initial active force. The joint owns its speed state so that <code>reinit</code> acts on
a state of the same model; the cart and the pendulum alias their speed to it.</p>
</html>"));
end StickSlip;
