model ControllerBench "The Controller block with its inputs bound: a reference step, a sine measurement, a feedforward pulse (edges between samples)"
  parameter Real T_s = 0.01;
  PendulumID.Controller c(T_s = T_s, K_p = 2.0, K_i = 5.0, K_d = 0.05, derivative_on_measurement = true, n_d = 2,
    delay = 1, u_max = 2.5, u_min = -0.5, u0 = 0.25);
equation
  c.r = if time >= 0.105 then 1.0 else 0.0;
  c.y = 0.4*sin(7.0*time);
  c.u_ff = if time >= 0.505 and time < 0.705 then 0.5 else 0.0;
  annotation (experiment(StopTime = 1.0));
end ControllerBench;
