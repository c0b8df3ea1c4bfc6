# Made by sculpt-bench stability --out docs/benchmarks; run from that directory.
set terminal pngcairo size 1300,750 noenhanced font ',10'
set output 'stability.png'
set datafile separator ','
set key outside right
set key autotitle columnhead
set grid
set title 'largest stable step of position Verlet, per mesh, material and damping'
set ylabel 'dt (ms)'
set logscale y
set xtics rotate by 60 right font ',7'
set bmargin 14
set style data linespoints
plot 'stability.csv' using ($0):($9*1e3):xtic(sprintf('%s %s %s', strcol(1), strcol(2), strcol(3) eq 'true' ? 'damped' : 'undamped')) pt 7 title 'measured (World bisection)', \
  '' using ($0):($8*1e3) pt 6 title 'power iteration 2/sqrt(lambda)', \
  '' using ($0):($7*1e3) pt 2 title 'Gershgorin bound (daemon)'
