within PendulumID;
model Pendulum "Pendulum on the cart's pivot with viscous, Coulomb and stiction friction (paper Eq. 6-8)"
  parameter Real m_p(unit = "kg") = 0.2 "Mass of the pendulum";
  parameter Real l(unit = "m") = 0.3 "Distance from the pivot to the centre of mass";
  parameter Real J_p(unit = "kg.m2") = 0.0 "Moment of inertia about the pivot; 0 means a uniform rod, (4/3)*m_p*l^2";
  parameter Real g(unit = "m/s2") = 9.81 "Gravitational acceleration";
  parameter Real k_fwp(unit = "N.m.s") = 1e-3 "Viscous friction coefficient of the pivot";
  parameter Real T_Kp(unit = "N.m") = 2e-3 "Coulomb (kinetic) friction torque of the pivot";
  parameter Real T_Sp(unit = "N.m") = 4e-3 "Stiction (maximum static friction) torque of the pivot";
  parameter Real w_Sp(unit = "rad/s") = 0.0 "Stribeck speed of the pivot: sliding friction falls from T_Sp to T_Kp as exp(-(w/w_Sp)^2) (0: no Stribeck effect)";
  parameter Real dk_fwp(unit = "N.m.s") = 0.0 "Direction asymmetry of the pivot's viscous friction: k_fwp + dk_fwp for w > 0, k_fwp - dk_fwp for w < 0";
  parameter Real dT_Kp(unit = "N.m") = 0.0 "Direction asymmetry of the pivot's Coulomb friction: T_Kp + dT_Kp for w > 0, T_Kp - dT_Kp for w < 0";
  parameter Real T_Op(unit = "N.m") = 0.0 "Constant offset torque on the pendulum towards +phi (a cable, a spring's preload)";
  parameter Real k_dp(unit = "N.m.s2") = 0.0 "Quadratic air drag of the pendulum: drag torque k_dp*w*|w|";
  parameter Real phi0(unit = "rad") = pi "Initial angle from the upward vertical (hanging: pi)";
  parameter Real w0(unit = "rad/s") = 0.0 "Initial angular speed";
  input Real a(unit = "m/s2", start = 0.0) "Cart acceleration";
  output Real phi(unit = "rad", start = phi0, fixed = true) "Angle from the upward vertical";
  output Real w(unit = "rad/s") "Angular speed";
  output Real alpha(unit = "rad/s2") "Angular acceleration";
  output Real T_A(unit = "N.m") "Active torque on the pendulum";
  Real T_F(unit = "N.m") "Friction torque in the pivot";
  Integer mode "Friction mode: +1 turning forward, 0 stuck, -1 turning backward";
  Boolean stuck "The pendulum is held by stiction";
protected
  final parameter Real J(unit = "kg.m2") = if J_p > 0 then J_p else 4/3*m_p*l^2 "Inertia used: J_p, or the uniform rod's";
  StickSlip friction(final m = J, final k_fw = k_fwp, final F_K = T_Kp, final F_S = T_Sp,
    final v_S = w_Sp, final dk_fw = dk_fwp, final dF_K = dT_Kp, final F_O = T_Op, final drag = k_dp,
    final v_start = w0) "Stick-slip friction of the pivot; owns the angular speed state";
equation
  assert(m_p > 0 and l > 0, "Pendulum: need m_p > 0 and l > 0");
  assert(w_Sp >= 0 and k_dp >= 0 and abs(dk_fwp) <= k_fwp and abs(dT_Kp) <= T_Kp,
    "Pendulum: need w_Sp >= 0, k_dp >= 0, |dk_fwp| <= k_fwp and |dT_Kp| <= T_Kp (no negative friction in either direction)");
  assert(J_p <= 0 or J_p >= m_p*l^2*(1 - 1e-12), "Pendulum: J_p is below m_p*l^2, the inertia of the mass m_p "
    + "concentrated at distance l; a body about its pivot has at least that (set J_p = 0 for a uniform rod)");
  T_A = m_p*l*(g*sin(phi) - a*cos(phi));
  friction.F_A = T_A;
  der(phi) = w;
  w = friction.v;
  alpha = friction.a;
  T_F = friction.F_F;
  mode = friction.mode;
  stuck = friction.stuck;
  annotation (Documentation(info = "<html>
<p>The pendulum on the cart's pivot (paper Eq. 6-8; pendfmu's docs/user-guide/model.md), phi
measured from the upward vertical (hanging at rest: phi = pi):</p>
<pre>
  J alpha = T_A - T_F,     dphi/dt = w,  dw/dt = alpha
  T_A = m_p l (g sin(phi) - a cos(phi))
  J = J_p, or (4/3) m_p l^2 (a uniform rod of half-length l) when J_p = 0
</pre>
<p>T_F is the stick-slip friction of <a href=\"modelica://PendulumID.StickSlip\">StickSlip</a>
with k_fw = k_fwp, F_K = T_Kp, F_S = T_Sp and its extras (Stribeck speed w_Sp, asymmetries
dk_fwp and dT_Kp, offset torque T_Op, quadratic air drag k_dp w |w|: 0 by default, the
paper's model): J alpha = T_A + T_Op - T_F, and the pendulum stays stuck while
T_A + T_Op is within the breakaway thresholds.</p>
<p>The FMU's parameter <code>solver_step</code> and local <code>t_mode</code> do not
exist here (see the package documentation).</p>
</html>"));
end Pendulum;
