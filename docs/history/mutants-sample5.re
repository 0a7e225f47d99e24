^runtime/src/control\.rs:207:9:\ replace\ ImpedanceController<S,\ M>::torque\ \->\ ControlOutput<S,\ N>\ with\ Default::default\(\)$
^runtime/src/control\.rs:223:52:\ replace\ \+\ with\ \-\ in\ ImpedanceController<S,\ M>::torque$
^runtime/src/control\.rs:234:51:\ replace\ \-\ with\ /\ in\ ImpedanceController<S,\ M>::torque$
^runtime/src/control\.rs:238:56:\ replace\ \+\ with\ \*\ in\ ImpedanceController<S,\ M>::torque$
^runtime/src/control\.rs:256:49:\ replace\ >\ with\ ==\ in\ ImpedanceController<S,\ M>::torque$
^runtime/src/control\.rs:285:26:\ delete\ !\ in\ ImpedanceController<S,\ M>::inverse_dynamics$
^runtime/src/control\.rs:295:41:\ replace\ \+\ with\ \-\ in\ ImpedanceController<S,\ M>::inverse_dynamics$
^runtime/src/control\.rs:315:62:\ replace\ \-\ with\ \+\ in\ ImpedanceController<S,\ M>::inverse_dynamics$
^runtime/src/control\.rs:328:71:\ replace\ \-\ with\ \+\ in\ ImpedanceController<S,\ M>::inverse_dynamics$
^runtime/src/control\.rs:360:5:\ replace\ jacobian_transpose\ \->\ ControlOutput<S,\ N>\ with\ Default::default\(\)$
^runtime/src/control\.rs:411:9:\ replace\ \&\&\ with\ \|\|\ in\ inputs_are_finite$
^runtime/src/control\.rs:403:9:\ replace\ \&\&\ with\ \|\|\ in\ inputs_are_finite$
^runtime/src/current_loop\.rs:82:9:\ replace\ CurrentController<S>::gains\ \->\ \&CurrentLoopGains<S>\ with\ Box::leak\(Box::new\(CurrentLoopGains::new\(Default::default\(\)\)\)\)$
^runtime/src/current_loop\.rs:114:9:\ replace\ CurrentController<S>::step_with_feedforward\ \->\ CurrentLoopOutput<S>\ with\ CurrentLoopOutput::new\(\)$
^runtime/src/current_loop\.rs:114:24:\ replace\ \+\ with\ \*\ in\ CurrentController<S>::step_with_feedforward$
^runtime/src/current_loop\.rs:120:72:\ replace\ \-\ with\ /\ in\ CurrentController<S>::step_with_feedforward$
^runtime/src/current_loop\.rs:127:57:\ replace\ <\ with\ >\ in\ CurrentController<S>::step_with_feedforward$
^runtime/src/current_loop\.rs:134:38:\ replace\ \+\ with\ \-\ in\ CurrentController<S>::step_with_feedforward$
^runtime/src/current_loop\.rs:136:47:\ delete\ \-\ in\ CurrentController<S>::step_with_feedforward$
^runtime/src/current_loop\.rs:176:9:\ replace\ CurrentLoopBank<S,\ N>::step\ \->\ \[CurrentLoopOutput<S>;\ N\]\ with\ \[CurrentLoopOutput::from\(Default::default\(\)\);\ N\]$
^runtime/src/effects\.rs:84:61:\ replace\ \&\&\ with\ \|\|\ in\ EffectState<S>::apply$
^runtime/src/effects\.rs:96:70:\ replace\ \*\ with\ /\ in\ EffectState<S>::apply$
^runtime/src/effects\.rs:100:43:\ replace\ \+\ with\ \-\ in\ EffectState<S>::apply$
^runtime/src/estimation\.rs:40:62:\ replace\ \*\ with\ /\ in\ low_pass_coefficient$
^runtime/src/estimation\.rs:64:35:\ replace\ /\ with\ %\ in\ EstimatorSettings<S>::at_rate$
^runtime/src/estimation\.rs:165:47:\ replace\ \+\ with\ \-\ in\ JointStateEstimator<S,\ N>::update$
^runtime/src/estimation\.rs:168:29:\ replace\ >\ with\ >=\ in\ JointStateEstimator<S,\ N>::update$
^runtime/src/estimation\.rs:177:70:\ replace\ \*\ with\ \+\ in\ JointStateEstimator<S,\ N>::update$
^runtime/src/estimation\.rs:179:33:\ replace\ \+=\ with\ \-=\ in\ JointStateEstimator<S,\ N>::update$
^runtime/src/estimation\.rs:210:38:\ replace\ \*\ with\ \+\ in\ ForceSensorCalibration<S,\ M>::force$
^runtime/src/fused\.rs:76:9:\ replace\ FusedImpedance::natural_inertia_torque\ \->\ Option<FusedTorque<Self::Scalar,\ N>>\ with\ None$
^runtime/src/fused\.rs:114:9:\ replace\ \&\&\ with\ \|\|\ in\ fused_torque$
^runtime/src/fused\.rs:116:8:\ delete\ !\ in\ fused_torque$
^runtime/src/fused\.rs:142:24:\ delete\ !\ in\ fused_torque$
^runtime/src/fused\.rs:159:23:\ replace\ \+=\ with\ \-=\ in\ fused_torque$
^runtime/src/linalg\.rs:43:27:\ replace\ \*\ with\ \+\ in\ transpose_mul_vec$
^runtime/src/linalg\.rs:62:5:\ replace\ all_finite\ \->\ bool\ with\ false$
^runtime/src/linalg\.rs:84:21:\ replace\ \-=\ with\ /=\ in\ cholesky_solve$
^runtime/src/linalg\.rs:92:35:\ replace\ /\ with\ \*\ in\ cholesky_solve$
^runtime/src/linalg\.rs:107:21:\ replace\ \+\ with\ \*\ in\ cholesky_solve$
^runtime/src/linalg\.rs:188:49:\ delete\ \-\ in\ LuFactors<S,\ N>::determinant$
^runtime/src/linalg\.rs:206:33:\ replace\ /\ with\ %\ in\ LuFactors<S,\ N>::reciprocal_condition_estimate$
^runtime/src/linalg\.rs:230:25:\ replace\ \+\ with\ \-\ in\ LuFactors<S,\ N>::solve$
^runtime/src/linalg\.rs:240:9:\ replace\ LuFactors<S,\ N>::solve_transposed\ \->\ Result<\[S;\ N\],\ SolveError>\ with\ Ok\(\[Default::default\(\);\ N\]\)$
^runtime/src/linalg\.rs:255:25:\ replace\ \+\ with\ \-\ in\ LuFactors<S,\ N>::solve_transposed$
^runtime/src/linalg\.rs:268:32:\ replace\ >\ with\ ==\ in\ LuFactors<S,\ N>::check_pivots$
^runtime/src/linalg\.rs:295:5:\ replace\ determinant\ \->\ S\ with\ Default::default\(\)$
^runtime/src/proxy\.rs:183:9:\ replace\ GodObject<'a,\ S,\ K,\ M>::translate\ \->\ bool\ with\ true$
^runtime/src/proxy\.rs:227:21:\ replace\ match\ guard\ finite\(hip\)\ with\ true\ in\ GodObject<'a,\ S,\ K,\ M>::render$
^runtime/src/proxy\.rs:243:53:\ replace\ >\ with\ >=\ in\ GodObject<'a,\ S,\ K,\ M>::render$
^runtime/src/proxy\.rs:275:9:\ replace\ GodObject<'a,\ S,\ K,\ M>::gather_candidates\ with\ \(\)$
^runtime/src/proxy\.rs:287:47:\ replace\ \+\ with\ \*\ in\ GodObject<'a,\ S,\ K,\ M>::gather_candidates$
^runtime/src/proxy\.rs:322:43:\ replace\ >\ with\ <\ in\ GodObject<'a,\ S,\ K,\ M>::constrained_proxy$
^runtime/src/proxy\.rs:367:25:\ delete\ match\ arm\ \(Some\(Constraint::Plane\{normal:a,\ \.\.\}\),\ Constraint::Plane\{normal:b,\ \.\.\}\)\ in\ GodObject<'a,\ S,\ K,\ M>::constrained_proxy$
^runtime/src/proxy\.rs:379:33:\ replace\ match\ guard\ count\ <\ MAX_CONSTRAINTS\ with\ true\ in\ GodObject<'a,\ S,\ K,\ M>::constrained_proxy$
^runtime/src/proxy\.rs:409:23:\ replace\ \+=\ with\ \-=\ in\ GodObject<'a,\ S,\ K,\ M>::goal$
^runtime/src/proxy\.rs:428:9:\ replace\ GodObject<'a,\ S,\ K,\ M>::sweep\ \->\ \(S,\ Option<\(usize,\ \[S;\ M\]\)>\)\ with\ \(Default::default\(\),\ Some\(\(1,\ \[Default::default\(\);\ M\]\)\)\)$
^runtime/src/proxy\.rs:447:33:\ replace\ <=\ with\ >\ in\ GodObject<'a,\ S,\ K,\ M>::sweep$
^runtime/src/proxy\.rs:471:13:\ delete\ match\ arm\ Shape::Mesh\(_\)\ \|\ Shape::MeshAt\{\.\.\}\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:485:49:\ replace\ \-\ with\ /\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:500:52:\ replace\ <\ with\ >\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:515:79:\ delete\ \-\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:545:52:\ replace\ \-\ with\ /\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:557:41:\ delete\ \-\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:571:56:\ replace\ <\ with\ ==\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:594:20:\ delete\ !\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:602:39:\ replace\ \+\ with\ \-\ in\ GodObject<'a,\ S,\ K,\ M>::safe_step$
^runtime/src/proxy\.rs:633:14:\ replace\ /\ with\ \*\ in\ convex_step$
^runtime/src/proxy\.rs:650:54:\ replace\ <<\ with\ >>\ in\ project_on_planes$
^runtime/src/proxy\.rs:662:60:\ replace\ <\ with\ <=\ in\ project_on_planes$
^runtime/src/proxy\.rs:690:20:\ replace\ /\ with\ %\ in\ equality_projection$
^runtime/src/proxy\.rs:693:16:\ delete\ !\ in\ equality_projection$
^runtime/src/proxy\.rs:696:40:\ replace\ \*\ with\ /\ in\ equality_projection$
^runtime/src/proxy\.rs:696:78:\ replace\ \*\ with\ /\ in\ equality_projection$
^runtime/src/proxy\.rs:701:46:\ replace\ \-\ with\ /\ in\ equality_projection$
^runtime/src/proxy\.rs:702:52:\ replace\ \-\ with\ /\ in\ equality_projection$
^runtime/src/proxy\.rs:703:52:\ replace\ \-\ with\ /\ in\ equality_projection$
^runtime/src/proxy\.rs:725:28:\ delete\ \-\ in\ equality_projection$
^runtime/src/real\.rs:67:9:\ replace\ Real::neg_mul_sub\ \->\ Self\ with\ Default::default\(\)$
^runtime/src/real\.rs:91:17:\ replace\ <\ with\ ==\ in\ Real::min$
^runtime/src/real\.rs:127:9:\ replace\ single::reduced\ \->\ \(f32,\ f32,\ i32\)\ with\ \(0\.0,\ 1\.0,\ 1\)$
^runtime/src/real\.rs:127:9:\ replace\ single::reduced\ \->\ \(f32,\ f32,\ i32\)\ with\ \(1\.0,\ 1\.0,\ 0\)$
^runtime/src/real\.rs:127:9:\ replace\ single::reduced\ \->\ \(f32,\ f32,\ i32\)\ with\ \(\-1\.0,\ 0\.0,\ \-1\)$
^runtime/src/real\.rs:127:51:\ replace\ \+\ with\ \*\ in\ single::reduced$
^runtime/src/real\.rs:129:39:\ replace\ \-\ with\ /\ in\ single::reduced$
^runtime/src/real\.rs:129:62:\ replace\ \*\ with\ /\ in\ single::reduced$
^runtime/src/real\.rs:135:9:\ replace\ single::polynomials\ \->\ \(f32,\ f32,\ i32\)\ with\ \(0\.0,\ \-1\.0,\ 1\)$
^runtime/src/real\.rs:135:9:\ replace\ single::polynomials\ \->\ \(f32,\ f32,\ i32\)\ with\ \(1\.0,\ \-1\.0,\ 0\)$
^runtime/src/real\.rs:135:9:\ replace\ single::polynomials\ \->\ \(f32,\ f32,\ i32\)\ with\ \(\-1\.0,\ 1\.0,\ \-1\)$
^runtime/src/real\.rs:136:29:\ replace\ \*\ with\ \+\ in\ single::polynomials$
^runtime/src/real\.rs:136:52:\ replace\ \*\ with\ /\ in\ single::polynomials$
^runtime/src/real\.rs:137:23:\ replace\ \-\ with\ \+\ in\ single::polynomials$
^runtime/src/real\.rs:137:59:\ replace\ \+\ with\ \-\ in\ single::polynomials$
^runtime/src/real\.rs:137:86:\ replace\ \*\ with\ /\ in\ single::polynomials$
^runtime/src/real\.rs:145:9:\ replace\ single::sin_cos\ \->\ \(f32,\ f32\)\ with\ \(1\.0,\ \-1\.0\)$
^runtime/src/real\.rs:152:22:\ delete\ \-\ in\ single::sin_cos$
^runtime/src/real\.rs:167:9:\ replace\ single::cos\ \->\ f32\ with\ 1\.0$
^runtime/src/real\.rs:269:5:\ replace\ double_mul_add\ \->\ f64\ with\ 0\.0$
^runtime/src/real\.rs:284:5:\ replace\ double_sin_cos\ \->\ \(f64,\ f64\)\ with\ \(1\.0,\ \-1\.0\)$
^runtime/src/render\.rs:107:9:\ replace\ Shape<S,\ V>::closest_surface_point\ \->\ Option<SurfacePoint<S>>\ with\ Some\(SurfacePoint::from\(Default::default\(\)\)\)$
^runtime/src/render\.rs:125:24:\ replace\ \-\ with\ \+\ in\ sub$
^runtime/src/render\.rs:129:24:\ replace\ \*\ with\ /\ in\ norm_squared$
^runtime/src/render\.rs:133:24:\ replace\ >\ with\ >=\ in\ circle$
^runtime/src/render\.rs:140:42:\ replace\ /\ with\ \*\ in\ circle$
^runtime/src/render\.rs:145:71:\ replace\ \*\ with\ /\ in\ circle$
^runtime/src/render\.rs:151:5:\ replace\ rectangle\ \->\ Option<SurfacePoint<S>>\ with\ Some\(SurfacePoint::from\(Default::default\(\)\)\)$
^runtime/src/render\.rs:151:39:\ replace\ >\ with\ >=\ in\ rectangle$
^runtime/src/render\.rs:157:70:\ replace\ \+\ with\ \*\ in\ rectangle$
^runtime/src/render\.rs:158:33:\ replace\ <\ with\ >\ in\ rectangle$
^runtime/src/render\.rs:162:29:\ replace\ \-\ with\ /\ in\ rectangle$
^runtime/src/render\.rs:172:42:\ replace\ \-\ with\ \+\ in\ rectangle$
^runtime/src/render\.rs:173:42:\ replace\ \+\ with\ \-\ in\ rectangle$
^runtime/src/render\.rs:181:5:\ replace\ closest_on_segment\ \->\ Point<S>\ with\ Point::new\(\)$
^runtime/src/render\.rs:184:61:\ replace\ /\ with\ \*\ in\ closest_on_segment$
^runtime/src/render\.rs:184:50:\ replace\ \*\ with\ /\ in\ closest_on_segment$
^runtime/src/render\.rs:189:31:\ replace\ \+\ with\ \*\ in\ closest_on_segment$
^runtime/src/render\.rs:198:14:\ replace\ <\ with\ ==\ in\ polygon$
^runtime/src/render\.rs:206:51:\ replace\ \-\ with\ /\ in\ polygon$
^runtime/src/render\.rs:206:67:\ replace\ \*\ with\ /\ in\ polygon$
^runtime/src/render\.rs:212:48:\ replace\ <\ with\ <=\ in\ polygon$
^runtime/src/render\.rs:226:24:\ replace\ <\ with\ ==\ in\ contour_function$
^runtime/src/render\.rs:232:30:\ replace\ \-\ with\ \+\ in\ contour_function$
^runtime/src/render\.rs:236:38:\ replace\ \+\ with\ \-\ in\ contour_function$
^runtime/src/render\.rs:237:29:\ replace\ /\ with\ %\ in\ contour_function$
^runtime/src/render\.rs:239:14:\ replace\ \+\ with\ \*\ in\ contour_function$
^runtime/src/render\.rs:256:36:\ replace\ \+\ with\ \-\ in\ contour_function$
^runtime/src/render\.rs:266:37:\ replace\ >\ with\ <\ in\ contour_function$
^runtime/src/render\.rs:280:73:\ replace\ <\ with\ <=\ in\ contour_function$
^runtime/src/render\.rs:289:5:\ replace\ contour_table\ \->\ Option<SurfacePoint<S>>\ with\ Some\(SurfacePoint::from\(Default::default\(\)\)\)$
^runtime/src/render\.rs:292:18:\ replace\ \|\|\ with\ \&\&\ in\ contour_table$
^runtime/src/render\.rs:295:22:\ replace\ \-\ with\ /\ in\ contour_table$
^runtime/src/render\.rs:299:23:\ replace\ \-\ with\ /\ in\ contour_table$
^runtime/src/render\.rs:302:27:\ replace\ \-\ with\ \+\ in\ contour_table$
^runtime/src/render\.rs:307:48:\ replace\ <\ with\ ==\ in\ contour_table$
^runtime/src/render\.rs:343:9:\ replace\ AntiDriftGrid<S>::node\ \->\ Option<Point<S>>\ with\ Some\(Point::from_iter\(\[Default::default\(\)\]\)\)$
^runtime/src/render\.rs:349:26:\ replace\ \&\&\ with\ \|\|\ in\ AntiDriftGrid<S>::update$
^runtime/src/render\.rs:354:85:\ replace\ <=\ with\ >\ in\ AntiDriftGrid<S>::update$
^runtime/src/render\.rs:358:75:\ replace\ \*\ with\ \+\ in\ AntiDriftGrid<S>::update$
^runtime/src/render\.rs:417:9:\ replace\ Scene<S,\ K,\ V>::grid\ \->\ \&AntiDriftGrid<S>\ with\ Box::leak\(Box::new\(AntiDriftGrid::from_iter\(\[Default::default\(\)\]\)\)\)$
^runtime/src/render\.rs:422:33:\ replace\ \&\&\ with\ \|\|\ in\ Scene<S,\ K,\ V>::render$
^runtime/src/render\.rs:481:9:\ replace\ Scene<S,\ K,\ V>::update_reference\ \->\ TaskReference<S,\ 2>\ with\ TaskReference::from\(Default::default\(\)\)$
^runtime/src/safety\.rs:58:9:\ replace\ SafeCommand<S,\ N>::any_clamped\ \->\ bool\ with\ true$
^runtime/src/safety\.rs:119:9:\ replace\ SafetyMonitor<S,\ N>::check_tick\ \->\ bool\ with\ false$
^runtime/src/safety\.rs:142:9:\ replace\ SafetyMonitor<S,\ N>::limit\ \->\ SafeCommand<S,\ N>\ with\ Default::default\(\)$
^runtime/src/safety\.rs:160:65:\ replace\ /\ with\ \*\ in\ SafetyMonitor<S,\ N>::limit$
^runtime/src/shape\.rs:33:5:\ replace\ dot\ \->\ S\ with\ Default::default\(\)$
^runtime/src/shape\.rs:50:5:\ replace\ add_scaled\ \->\ \[S;\ M\]\ with\ \[Default::default\(\);\ M\]$
^runtime/src/shape\.rs:64:25:\ replace\ \&\&\ with\ \|\|\ in\ unit$
^runtime/src/shape\.rs:77:7:\ replace\ >\ with\ ==\ in\ exceeds$
^runtime/src/shape\.rs:98:20:\ replace\ <\ with\ >\ in\ perpendicular$
^runtime/src/shape\.rs:167:28:\ replace\ <=\ with\ >\ in\ closest_on_triangle$
^runtime/src/shape\.rs:176:27:\ replace\ \*\ with\ \+\ in\ closest_on_triangle$
^runtime/src/shape\.rs:178:20:\ replace\ /\ with\ \*\ in\ closest_on_triangle$
^runtime/src/shape\.rs:187:22:\ replace\ \-\ with\ \+\ in\ closest_on_triangle$
^runtime/src/shape\.rs:188:11:\ replace\ <=\ with\ >\ in\ closest_on_triangle$
^runtime/src/shape\.rs:190:48:\ replace\ \-\ with\ /\ in\ closest_on_triangle$
^runtime/src/shape\.rs:193:22:\ replace\ \&\&\ with\ \|\|\ in\ closest_on_triangle$
^runtime/src/shape\.rs:194:27:\ replace\ /\ with\ %\ in\ closest_on_triangle$
^runtime/src/shape\.rs:194:46:\ replace\ \-\ with\ \+\ in\ closest_on_triangle$
^runtime/src/shape\.rs:198:8:\ delete\ !\ in\ closest_on_triangle$
^runtime/src/shape\.rs:203:58:\ replace\ \-\ with\ /\ in\ closest_on_triangle$
^runtime/src/shape\.rs:232:35:\ replace\ \|\|\ with\ \&\&\ in\ triangle_entry$
^runtime/src/shape\.rs:235:66:\ replace\ \*\ with\ /\ in\ triangle_entry$
^runtime/src/shape\.rs:240:29:\ delete\ \-\ in\ triangle_entry$
^runtime/src/shape\.rs:257:27:\ replace\ \*\ with\ /\ in\ triangle_entry$
^runtime/src/shape\.rs:261:24:\ replace\ \-\ with\ \+\ in\ triangle_entry$
^runtime/src/shape\.rs:261:61:\ replace\ \-\ with\ \+\ in\ triangle_entry$
^runtime/src/shape\.rs:270:52:\ replace\ \&\&\ with\ \|\|\ in\ triangle_entry$
^runtime/src/shape\.rs:283:64:\ replace\ /\ with\ %\ in\ triangle_entry$
^runtime/src/shape\.rs:303:5:\ replace\ box_distance_squared\ \->\ S\ with\ Default::default\(\)$
^runtime/src/shape\.rs:311:21:\ replace\ >\ with\ <\ in\ box_distance_squared$
^runtime/src/shape\.rs:331:5:\ replace\ segment_box_entry\ \->\ Option<S>\ with\ None$
^runtime/src/shape\.rs:338:20:\ replace\ >\ with\ <\ in\ segment_box_entry$
^runtime/src/shape\.rs:339:45:\ replace\ \-\ with\ \+\ in\ segment_box_entry$
^runtime/src/shape\.rs:346:21:\ replace\ <\ with\ >\ in\ segment_box_entry$
^runtime/src/shape\.rs:379:9:\ replace\ Mesh<'a,\ S,\ M>::faces_near\ \->\ Option<usize>\ with\ Some\(0\)$
^runtime/src/shape\.rs:427:9:\ replace\ Mesh<'a,\ S,\ M>::nearest_first\ with\ \(\)$
^runtime/src/shape\.rs:451:22:\ replace\ >\ with\ >=\ in\ Mesh<'a,\ S,\ M>::nearest_first$
^runtime/src/shape\.rs:470:47:\ replace\ <\ with\ >\ in\ Mesh<'a,\ S,\ M>::nearest_first$
^runtime/src/shape\.rs:491:53:\ replace\ <\ with\ <=\ in\ Mesh<'a,\ S,\ M>::closest$
^runtime/src/shape\.rs:607:9:\ replace\ Shape<'a,\ S,\ M>::half_space\ \->\ Option<Self>\ with\ None$
^runtime/src/shape\.rs:627:90:\ replace\ <\ with\ <=\ in\ Shape<'a,\ S,\ M>::closest$
^runtime/src/shape\.rs:646:57:\ replace\ >\ with\ ==\ in\ Shape<'a,\ S,\ M>::closest$
^runtime/src/shape\.rs:665:69:\ replace\ <\ with\ >\ in\ Shape<'a,\ S,\ M>::closest$
^runtime/src/shape\.rs:700:9:\ replace\ Shape<'a,\ S,\ M>::project_inside\ \->\ Option<\[S;\ M\]>\ with\ Some\(\[Default::default\(\);\ M\]\)$
^runtime/src/shape\.rs:718:43:\ replace\ >\ with\ <\ in\ Shape<'a,\ S,\ M>::project_inside$
^runtime/src/shape\.rs:742:57:\ replace\ \-\ with\ \+\ in\ Shape<'a,\ S,\ M>::project_inside$
^runtime/src/shape\.rs:743:24:\ replace\ >\ with\ ==\ in\ Shape<'a,\ S,\ M>::project_inside$
^runtime/src/shape\.rs:750:37:\ replace\ >\ with\ <\ in\ Shape<'a,\ S,\ M>::project_inside$
^runtime/src/shape\.rs:761:8:\ delete\ !\ in\ sphere$
^runtime/src/shape\.rs:769:22:\ replace\ \*\ with\ /\ in\ sphere$
^runtime/src/shape\.rs:782:50:\ replace\ <\ with\ >\ in\ sphere$
^runtime/src/shape\.rs:799:69:\ replace\ <\ with\ ==\ in\ oriented_box$
^runtime/src/shape\.rs:810:47:\ replace\ <\ with\ <=\ in\ oriented_box$
^runtime/src/shape\.rs:844:29:\ replace\ \-\ with\ /\ in\ outward$
^runtime/src/shape\.rs:855:8:\ delete\ !\ in\ cylinder$
^runtime/src/shape\.rs:866:20:\ replace\ >\ with\ ==\ in\ cylinder$
^runtime/src/shape\.rs:868:30:\ replace\ <\ with\ ==\ in\ cylinder$
^runtime/src/shape\.rs:870:31:\ replace\ <\ with\ <=\ in\ cylinder$
^runtime/src/shape\.rs:881:21:\ replace\ match\ guard\ axial\.abs\(\)\ >=\ half\ with\ true\ in\ cylinder$
^runtime/src/spatial\.rs:67:9:\ replace\ MinDistanceScene<'a,\ S,\ K,\ M>::contact\ \->\ Option<usize>\ with\ Some\(0\)$
^runtime/src/spatial\.rs:78:84:\ replace\ <=\ with\ >\ in\ MinDistanceScene<'a,\ S,\ K,\ M>::free_space$
^runtime/src/spatial\.rs:94:9:\ replace\ MinDistanceScene<'a,\ S,\ K,\ M>::render\ \->\ Option<\(\[S;\ M\],\ S,\ S\)>\ with\ None$
^runtime/src/spatial\.rs:118:59:\ replace\ >\ with\ ==\ in\ MinDistanceScene<'a,\ S,\ K,\ M>::render$
^runtime/src/tick\.rs:94:9:\ replace\ <impl\ ReferenceSource<S,\ 2>\ for\ Scene<S,\ K,\ V>>::update_reference\ \->\ TaskReference<S,\ 2>\ with\ TaskReference::from\(Default::default\(\)\)$
^runtime/src/tick\.rs:332:31:\ replace\ \+\ with\ \*\ in\ HapticLoop<R,\ Source,\ N,\ M>::sensed$
^runtime/src/tick\.rs:377:9:\ replace\ HapticLoop<R,\ Source,\ N,\ M>::current_tick\ \->\ \(\[CurrentLoopOutput<R::Scalar>;\ N\],\ bool\)\ with\ \(\[CurrentLoopOutput::new\(Default::default\(\)\);\ N\],\ true\)$
^runtime/src/tick\.rs:388:13:\ replace\ \&\&\ with\ \|\|\ in\ HapticLoop<R,\ Source,\ N,\ M>::current_tick$
