within PendulumID;
model Cart "Cart on a lead screw driven by the DC motor, with viscous, Coulomb and stiction friction (paper Eq. 2-5)"
  parameter Real m_c(unit = "kg") = 3.0 "Effective mass of the cart, motor inertia included";
  parameter Real m_p(unit = "kg") = 0.2 "Mass of the pendulum (0: pendulum removed)";
  parameter Real eta(unit = "1") = 0.4 "Efficiency of the lead screw";
  parameter Real k_M(unit = "N.m/A") = 0.06 "Torque constant of the DC motor";
  parameter Real k_D(unit = "1/m") = 628.3 "Translation gain of the lead screw (2*pi/pitch)";
  parameter Real l(unit = "m") = 0.3 "Distance from the pivot to the pendulum's centre of mass";
  parameter Real k_fwc(unit = "N.s/m") = 30.0 "Viscous friction coefficient of the cart";
  parameter Real F_Kc(unit = "N") = 8.0 "Coulomb (kinetic) friction force of the cart";
  parameter Real F_Sc(unit = "N") = 12.0 "Stiction (maximum static friction) force of the cart";
  parameter Real v_Sc(unit = "m/s") = 0.0 "Stribeck speed of the cart: sliding friction falls from F_Sc to F_Kc as exp(-(v/v_Sc)^2) (0: no Stribeck effect)";
  parameter Real dk_fwc(unit = "N.s/m") = 0.0 "Direction asymmetry of the cart's viscous friction: k_fwc + dk_fwc for v > 0, k_fwc - dk_fwc for v < 0";
  parameter Real dF_Kc(unit = "N") = 0.0 "Direction asymmetry of the cart's Coulomb friction: F_Kc + dF_Kc for v > 0, F_Kc - dF_Kc for v < 0";
  parameter Real F_Oc(unit = "N") = 0.0 "Constant offset force on the cart along +x (cable drag, a tilted track)";
  parameter Real k_u(unit = "N") = 0.0 "Motor force per unit of the command u, before the screw's efficiency (0: no command path)";
  parameter Real k_emf(unit = "N.s/m") = 0.0 "Back-EMF of a voltage-driven motor: the command path's force falls by k_emf*v";
  parameter Real tau_e(unit = "s") = 0.0 "Electrical lag of the command path: tau_e*dF_e/dt = k_u*u - k_emf*v - F_e (0: no lag, the force follows u at once)";
  parameter Real eta_back(unit = "1") = -1.0 "Back-drive efficiency of the screw: -1 (default) A(eta) = max(0, (2*eta-1)/eta) as the paper; 0 self-locking whatever eta; in (0, 1] this efficiency";
  parameter Real x0(unit = "m") = 0.0 "Initial position";
  parameter Real v0(unit = "m/s") = 0.0 "Initial speed";
  input Real I(unit = "A", start = 0.0) "Motor current";
  input Real u(unit = "1", start = 0.0) "Drive command: normalized PWM duty or voltage command (force k_u*u, used when k_u != 0)";
  input Real phi(unit = "rad", start = pi) "Pendulum angle from the upward vertical (used when back-drivable: eta > 0.5 and eta_back = -1, or eta_back > 0)";
  input Real w(unit = "rad/s", start = 0.0) "Pendulum angular speed (used when back-drivable: eta > 0.5 and eta_back = -1, or eta_back > 0)";
  input Real alpha(unit = "rad/s2", start = 0.0) "Pendulum angular acceleration (used when back-drivable: eta > 0.5 and eta_back = -1, or eta_back > 0)";
  output Real x(unit = "m", start = x0, fixed = true) "Cart position";
  output Real v(unit = "m/s") "Cart speed";
  output Real a(unit = "m/s2") "Cart acceleration";
  output Real F_A(unit = "N") "Active force on the cart";
  output Real F_e(unit = "N", start = 0, fixed = true) "Lagged force of the command path (state of the electrical lag; stays 0 when tau_e = 0)";
  Real F_F(unit = "N") "Friction force on the cart";
  Integer mode "Friction mode: +1 sliding forward, 0 stuck, -1 sliding backward";
  Boolean stuck "The cart is held by stiction";
protected
  final parameter Real A(unit = "1") = if eta_back >= 0 then eta_back elseif eta > 0.5 then (2*eta - 1)/eta else 0 "Back-drive efficiency: A(eta), or eta_back when it is >= 0";
  Real F_cmd(unit = "N") "Force of the command path before the screw";
  StickSlip friction(final m = m_c + m_p, final k_fw = k_fwc, final F_K = F_Kc, final F_S = F_Sc,
    final v_S = v_Sc, final dk_fw = dk_fwc, final dF_K = dF_Kc, final F_O = F_Oc, final drag = 0,
    final v_start = v0) "Stick-slip friction of the screw; owns the speed state";
equation
  assert(m_c > 0 and eta > 0 and eta <= 1, "Cart: need m_c > 0 and 0 < eta <= 1");
  assert(k_emf >= 0 and tau_e >= 0 and (eta_back == -1 or (eta_back >= 0 and eta_back <= 1)),
    "Cart: need k_emf >= 0, tau_e >= 0 and eta_back = -1 or 0 <= eta_back <= 1");
  assert(v_Sc >= 0 and abs(dk_fwc) <= k_fwc and abs(dF_Kc) <= F_Kc,
    "Cart: need v_Sc >= 0, |dk_fwc| <= k_fwc and |dF_Kc| <= F_Kc (no negative friction in either direction)");
  der(F_e) = if tau_e > 0 then (k_u*u - k_emf*v - F_e)/tau_e else 0;
  F_cmd = if tau_e > 0 then F_e else k_u*u - k_emf*v;
  F_A = eta*(k_M*k_D*I + F_cmd) + A*m_p*l*(w^2*sin(phi) - alpha*cos(phi));
  friction.F_A = F_A;
  der(x) = v;
  v = friction.v;
  a = friction.a;
  F_F = friction.F_F;
  mode = friction.mode;
  stuck = friction.stuck;
  annotation (Documentation(info = "<html>
<p>The cart on the lead screw (paper Eq. 2-5; pendfmu's docs/user-guide/model.md):</p>
<pre>
  (m_c + m_p) a = F_A - F_F,     dx/dt = v,  dv/dt = a
  F_A = eta F_u + A m_p l (w^2 sin(phi) - alpha cos(phi))
  F_u = k_M k_D I + F_cmd
  F_cmd = k_u u - k_emf v                                  (tau_e = 0)
  tau_e dF_e/dt = k_u u - k_emf v - F_e,  F_cmd = F_e       (tau_e &gt; 0)
  A = A(eta) = max(0, (2 eta - 1)/eta)                      (eta_back = -1, the paper's)
  A = eta_back                                              (0 &le; eta_back &le; 1)
</pre>
<p>The drive extras (README, Drives) are off by default (k_u = k_emf = tau_e = 0,
eta_back = -1): then F_u = k_M k_D I and A = A(eta), the paper's equations. The command u
is a normalized PWM duty or a voltage; k_u its force per unit; k_emf the back-EMF of a
voltage-driven motor; tau_e the electrical lag of the u path only (F_e starts at 0).</p>
<p>F_F is the stick-slip friction of <a href=\"modelica://PendulumID.StickSlip\">StickSlip</a>
with k_fw = k_fwc, F_K = F_Kc, F_S = F_Sc and its extras (Stribeck speed v_Sc, asymmetries
dk_fwc and dF_Kc, offset force F_Oc: 0 by default, the paper's model). The offset acts
beside F_A: (m_c + m_p) a = F_A + F_Oc - F_F, and the cart stays stuck while F_A + F_Oc is
within the breakaway thresholds. A self-locking screw (A = 0: eta &le; 0.5, or eta_back = 0)
ignores the pendulum inputs <code>phi</code>, <code>w</code>, <code>alpha</code>; with a
back-drivable one (A &gt; 0) cart and pendulum form an algebraic loop.</p>
<p>The FMU's parameter <code>solver_step</code> and local <code>t_mode</code> do not
exist here (see the package documentation).</p>
</html>"));
end Cart;
