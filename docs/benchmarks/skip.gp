# Made by sculpt-bench skip --out docs/benchmarks; run from that directory.
set terminal pngcairo size 1300,750 noenhanced font ',10'
set output 'skip.png'
set datafile separator ','
set key outside right
set key autotitle columnhead
set grid
set multiplot layout 1,3 title 'skip: builtin:default (a tool sculpting one mesh)'
set key inside top right
set logscale x
set format x '%g'
set title 'bytes per frame (60 fps) vs delta tolerance'
set xlabel 'tolerance (m)'
set ylabel 'bytes per frame'
set logscale y
plot 'skip.csv' using (strcol(2) ne 'sleep_speed' ? $4 : NaN):11 smooth unique with linespoints pt 7 title 'active', '' using (strcol(2) ne 'sleep_speed' ? $4 : NaN):12 smooth unique with linespoints pt 6 title 'idle (keep-alive)'
set title 'ms per tick vs sleep speed'
set xlabel 'sleep_speed (m/s)'
set ylabel 'ms per tick'
plot 'skip.csv' using (strcol(2) ne 'tolerance' ? $3 : NaN):5 smooth unique with linespoints pt 7 title 'all awake', '' using (strcol(2) ne 'tolerance' ? $3 : NaN):6 smooth unique with linespoints pt 5 title 'skipping (sculpting)', '' using (strcol(2) ne 'tolerance' ? $3 : NaN):7 smooth unique with linespoints pt 6 title 'idle'
set title 'what sleeping freezes'
set ylabel 'max distance from never-sleeping run (m)'
plot 'skip.csv' using (strcol(2) ne 'tolerance' ? $3 : NaN):18 smooth unique with linespoints pt 7 title 'rest error'
unset multiplot
