# Made by sculpt-bench stability_scenes --out docs/benchmarks; run from that directory.
set terminal pngcairo size 1300,750 noenhanced font ',10'
set output 'stability_scenes.png'
set datafile separator ','
set key outside right
set key autotitle columnhead
set grid
set title 'measured critical step / the substep the daemon runs (shipped scenes)'
set ylabel 'margin'
set logscale y
set xtics rotate by 45 right font ',8'
set bmargin 10
set style fill solid 0.6
set boxwidth 0.6
plot 'stability_scenes.csv' using ($0):11:xtic(sprintf('%s %s', strcol(1), strcol(2))) with boxes title 'margin', '' using ($0):12 with lines lw 2 title 'required (1/substep_safety)'
