# Made by sculpt-bench accuracy --out docs/benchmarks; run from that directory.
set terminal pngcairo size 1300,750 noenhanced font ',10'
set output 'accuracy_mesh.png'
set datafile separator ','
set key outside right
set key autotitle columnhead
set grid
set multiplot layout 1,2 title 'accuracy: mesh (max position error over the run; dashed = double)'
set logscale xy
set format x '%g'
set format y '%.0e'
set ylabel 'max position error (m)'
set xlabel 'passes over the springs (deterministic cost)'
unset key
plot 'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'verlet' && strcol(3) eq 'float' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 1 dt 1 title 'verlet float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'verlet' && strcol(3) eq 'double' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 2 dt 2 title 'verlet double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'velocity_verlet' && strcol(3) eq 'float' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 3 dt 1 title 'velocity_verlet float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'velocity_verlet' && strcol(3) eq 'double' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 4 dt 2 title 'velocity_verlet double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'symplectic_euler' && strcol(3) eq 'float' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 5 dt 1 title 'symplectic_euler float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'symplectic_euler' && strcol(3) eq 'double' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 6 dt 2 title 'symplectic_euler double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'explicit_euler' && strcol(3) eq 'float' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 7 dt 1 title 'explicit_euler float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'explicit_euler' && strcol(3) eq 'double' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 8 dt 2 title 'explicit_euler double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'implicit_euler' && strcol(3) eq 'float' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 9 dt 1 title 'implicit_euler float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'implicit_euler' && strcol(3) eq 'double' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 10 dt 2 title 'implicit_euler double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'float' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 11 dt 1 title 'xpbd float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'float' && $6 == 4 ? $9 : NaN):10 with linespoints lw 1.5 pt 12 dt 1 title 'xpbd float x4', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'float' && $6 == 16 ? $9 : NaN):10 with linespoints lw 1.5 pt 13 dt 1 title 'xpbd float x16', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'double' && $6 == 1 ? $9 : NaN):10 with linespoints lw 1.5 pt 1 dt 2 title 'xpbd double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'double' && $6 == 4 ? $9 : NaN):10 with linespoints lw 1.5 pt 2 dt 2 title 'xpbd double x4', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'double' && $6 == 16 ? $9 : NaN):10 with linespoints lw 1.5 pt 3 dt 2 title 'xpbd double x16'
set xlabel 'run time (s)'
set key outside right
plot 'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'verlet' && strcol(3) eq 'float' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 1 dt 1 title 'verlet float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'verlet' && strcol(3) eq 'double' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 2 dt 2 title 'verlet double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'velocity_verlet' && strcol(3) eq 'float' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 3 dt 1 title 'velocity_verlet float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'velocity_verlet' && strcol(3) eq 'double' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 4 dt 2 title 'velocity_verlet double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'symplectic_euler' && strcol(3) eq 'float' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 5 dt 1 title 'symplectic_euler float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'symplectic_euler' && strcol(3) eq 'double' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 6 dt 2 title 'symplectic_euler double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'explicit_euler' && strcol(3) eq 'float' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 7 dt 1 title 'explicit_euler float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'explicit_euler' && strcol(3) eq 'double' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 8 dt 2 title 'explicit_euler double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'implicit_euler' && strcol(3) eq 'float' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 9 dt 1 title 'implicit_euler float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'implicit_euler' && strcol(3) eq 'double' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 10 dt 2 title 'implicit_euler double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'float' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 11 dt 1 title 'xpbd float', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'float' && $6 == 4 ? $8 : NaN):10 with linespoints lw 1.5 pt 12 dt 1 title 'xpbd float x4', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'float' && $6 == 16 ? $8 : NaN):10 with linespoints lw 1.5 pt 13 dt 1 title 'xpbd float x16', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'double' && $6 == 1 ? $8 : NaN):10 with linespoints lw 1.5 pt 1 dt 2 title 'xpbd double', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'double' && $6 == 4 ? $8 : NaN):10 with linespoints lw 1.5 pt 2 dt 2 title 'xpbd double x4', \
  'accuracy.csv' using (strcol(1) eq 'mesh' && strcol(2) eq 'xpbd' && strcol(3) eq 'double' && $6 == 16 ? $8 : NaN):10 with linespoints lw 1.5 pt 3 dt 2 title 'xpbd double x16'
unset multiplot
