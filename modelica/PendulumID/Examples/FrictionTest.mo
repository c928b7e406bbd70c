within PendulumID.Examples;
model FrictionTest "The paper's test of the stick-slip friction law (Fig. 3): a 0.5 kg mass under a sine force"
  parameter Real F_0(unit = "N") = 1.0 "Amplitude of the force";
  parameter Real P(unit = "s") = 0.63 "Period of the force";
  PendulumID.StickSlip mass(m = 0.5, k_fw = 2.0, F_K = 0.3, F_S = 0.8) "The mass with its friction";
  Real x(unit = "m", start = 0, fixed = true) "Position of the mass";
equation
  mass.F_A = F_0*sin(2*pi*time/P);
  der(x) = mass.v;
  annotation (
    experiment(StopTime = 2.0, Interval = 1e-3, Tolerance = 1e-8),
    Documentation(info = "<html>
<p>Paper Fig. 3: mass m = 0.5 kg, force F_A = 1 N sin(2 pi t / 0.63 s), F_S = 0.8 N,
F_K = 0.3 N, k_fw = 2 N.s/m. The mass is stuck until the force exceeds F_S, at
t = 0.63 asin(0.8)/(2 pi) = 0.0929777 s, and rests again for a while around each
reversal of the motion; since a stuck mass keeps no memory, it breaks away again
whenever |F_A| passes F_S, at 0.0929777 s + k 0.315 s.</p>
</html>"));
end FrictionTest;
