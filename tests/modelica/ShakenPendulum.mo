within;
model ShakenPendulum "Test bench: the pendulum, hanging at rest, its pivot shaken sinusoidally"
  parameter Real a_0(unit = "m/s2") = 2.0 "Amplitude of the pivot's acceleration";
  parameter Real f_a(unit = "Hz") = 1.0 "Frequency of the pivot's acceleration";
  PendulumID.Pendulum pendulum "Pendulum with the library's default parameters";
equation
  pendulum.a = a_0*sin(2*PendulumID.pi*f_a*time);
  annotation (Documentation(info = "<html>
<p>Drives the pendulum's input <code>a</code> by an equation (rumoca 0.10.2 takes no
time-varying inputs), so that pendfmu's tests can compare the Modelica pendulum with the
Pendulum FMU under a known pivot acceleration a = a_0 sin(2 pi f_a t). Hanging at rest,
the pendulum sticks until m_p l |a| exceeds T_Sp, then swings.</p>
</html>"));
end ShakenPendulum;
