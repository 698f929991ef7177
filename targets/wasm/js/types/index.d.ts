export { Scene, InstancedScene, simdSupported, moduleVariant } from './core.js';
export type { Vec3Like, SceneOptions, LoadOptions, Indices, Hit, AllHit, SceneInfo, InstanceHit, Instances, InstancedSceneInfo } from './core.js';
/** Loads the inlined module (the SIMD one where supported); Scene.build does it too. */
export declare function init(): Promise<void>;
/** Loads it synchronously (the synchronous calls do it on first use). */
export declare function initSync(): void;
