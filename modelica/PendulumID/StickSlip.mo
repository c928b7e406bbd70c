within PendulumID;
model StickSlip "Viscous, Coulomb and stiction friction of one joint as a three-mode hybrid model"
  parameter Real m "Inertia of the joint: mass [kg] of a slider, or moment of inertia [kg.m2] of a rotary joint";
  parameter Real k_fw "Viscous friction coefficient [N.s/m or N.m.s]";
  parameter Real F_K "Coulomb (kinetic) friction [N or N.m]";
  parameter Real F_S "Stiction, the maximum static friction [N or N.m]";
  parameter Real v_start = 0 "Initial speed [m/s or rad/s]";
  parameter Real v_S = 0 "Stribeck speed [m/s or rad/s]; 0: no Stribeck effect";
  parameter Real dk_fw = 0 "Direction asymmetry of k_fw: k_fw + dk_fw forward, k_fw - dk_fw backward";
  parameter Real dF_K = 0 "Direction asymmetry of F_K: F_K + dF_K forward, F_K - dF_K backward";
  parameter Real F_O = 0 "Constant offset force (or torque) acting beside F_A";
  parameter Real drag = 0 "Quadratic drag coefficient: drag*v*|v| [N.s2/m2 or N.m.s2]";
  final parameter Real F_break_fwd = max(F_S, F_K + dF_K) "Breakaway threshold forward: a joint at rest moves when F_A + F_O exceeds it";
  final parameter Real F_break_back = max(F_S, F_K - dF_K) "Breakaway threshold backward: a joint at rest moves when -(F_A + F_O) exceeds it";
  input Real F_A "Active force (or torque) on the joint";
  output Real v(start = v_start, fixed = true) "Speed of the joint";
  output Real a "Acceleration of the joint";
  output Real F_F "Friction force (or torque)";
  Integer mode(start = 0) "Friction mode: +1 sliding forward, 0 stuck, -1 sliding backward";
  Boolean stuck "The joint is held by stiction";
protected
  Real F_N "Net force the friction must hold at rest: F_A + F_O";
  Real F_Kd "Coulomb friction of the direction of motion";
  Real F_Str "Stribeck excess over F_Kd in the direction of motion";
equation
  F_N = F_A + F_O;
  F_Kd = F_K + dF_K*mode;
  F_Str = if v_S > 0 then (F_S - F_Kd)*exp(-(v/v_S)^2) else 0;
  F_F = if mode == 0 then F_N else (k_fw + dk_fw*mode)*v + (F_Kd + F_Str)*mode + drag*v*abs(v);
  a = if mode == 0 then 0 else (F_N - F_F)/m;
  der(v) = a;
  stuck = mode == 0;
  // The initial mode is set in a "when initial()" branch rather than by an initial
  // equation: rumoca 0.10.2 cannot order an initial equation for mode that reads an
  // active force depending on another joint's mode (see modelica/README.md).
  when initial() then
    mode = if v_start > 0 then 1 elseif v_start < 0 then -1
      elseif F_N > F_break_fwd then 1 elseif F_N < -F_break_back then -1 else 0;
  elsewhen {pre(mode) == 0 and (F_N > F_break_fwd or F_N < -F_break_back), pre(mode) == 1 and v < 0, pre(mode) == -1 and v > 0} then
    mode = if F_N > F_break_fwd then 1 elseif F_N < -F_break_back then -1 else 0;
    reinit(v, 0);
  end when;
  annotation (Documentation(info = "<html>
<p>The friction law of the paper's model (pendfmu's <code>docs/user-guide/model.md</code>, and
its <code>friction.h</code>), with speed <i>v</i>, active force <i>F_A</i> and inertia <i>m</i>:</p>
<pre>
  m dv/dt = F_A - F_F
  sliding (mode = +1 or -1):  F_F = k_fw v + F_K mode
  stuck   (mode = 0):         F_F = F_A,  v = 0,  dv/dt = 0
</pre>
<p>Optional extras (pendfmu's docs, user-guide/friction.md, section Friction law extras), all off at their default 0: with
F_N = F_A + F_O (a constant offset force) and the direction d = mode,</p>
<pre>
  m dv/dt = F_N - F_F
  sliding: F_F = (k_fw + d dk_fw) v + d (F_K(d) + (F_S - F_K(d)) exp(-(v/v_S)^2)) + drag v |v|
           F_K(d) = F_K + d dF_K, the exp term only when v_S &gt; 0 (Stribeck)
  stuck:   F_F = F_N while F_N is within [-max(F_S, F_K(-1)), max(F_S, F_K(+1))]
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
